"""The RC-233 wire protocol, sans-I/O: command models, registry, replies, framing, programs.

Nothing here does I/O or imports asyncio; the simulator and the gateway both stand on it.
"""

from gateway.protocol import commands
from gateway.protocol.command_text import REGISTRY, Context, command_union, parse, parse_statement
from gateway.protocol.framing import (
    Framing,
    Series,
    checksum,
    encode_command,
    framing_switch,
    from_wire,
    to_wire,
)
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.protocol.program import Program, Statement, parse_program
from gateway.protocol.replies import ReplyValue, decode_reply, encode_reply, reply_length
from gateway.protocol.reply_parser import ReplyParser
from gateway.protocol.spec import CommandSpec, Effect, Form, Persist, ReplyFormat, Scope

__all__ = [
    "REGISTRY",
    "Command",
    "CommandSpec",
    "Context",
    "Effect",
    "Form",
    "Framing",
    "Persist",
    "PositionFormat",
    "Program",
    "ReplyFormat",
    "ReplyParser",
    "ReplyValue",
    "Scope",
    "Series",
    "Statement",
    "checksum",
    "command_union",
    "commands",
    "decode_reply",
    "encode_command",
    "encode_reply",
    "framing_switch",
    "from_wire",
    "parse",
    "parse_program",
    "parse_statement",
    "reply_length",
    "to_wire",
]
