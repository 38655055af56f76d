"""Hand-made replies fed to a state cache, decoded as the scheduler hands them over."""

from __future__ import annotations

from gateway.bus.state import (
    StateCache,
)
from gateway.protocol.command_text import parse
from gateway.protocol.replies import decode_reply

LOOP = "L1"


def reply(cache: StateCache, text: str, data: str | None, time: float, body: str = "1") -> None:
    """Feed the reply ``data`` (None: '>') of ``body`` to the command ``text``."""
    command = parse(text)
    value = None if data is None else decode_reply(command.reply_format, data)
    cache.observe(LOOP, body, command, value, time)
