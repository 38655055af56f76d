"""The RC-233 wire protocol, sans-I/O: command models, registry, replies, framing, programs.

Nothing here does I/O or imports asyncio; the simulator and the gateway both stand on it.
"""

from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.protocol.registry import REGISTRY, Context, command_union, parse, parse_statement
from gateway.protocol.spec import CommandSpec, Effect, Form, Persist, ReplyFormat, Scope

__all__ = [
    "REGISTRY",
    "Command",
    "CommandSpec",
    "Context",
    "Effect",
    "Form",
    "Persist",
    "PositionFormat",
    "ReplyFormat",
    "Scope",
    "command_union",
    "parse",
    "parse_statement",
]
