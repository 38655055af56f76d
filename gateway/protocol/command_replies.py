"""Reading a reply as the reply to one command: typed values, and the framing it shows.

``decode_for`` is the one place where a command's reply data becomes its typed value (the
format alone is not enough for ``9{bit}``, whose bits 4 and 5 answer the mode, or for ``QJ``
and ``QSE``, which allow 0-1 where ``QS`` allows 0-2). The other functions read what a reply
says about the framing the controller uses (§10 EE, EL, ER, SUM): whether data carries a
checksum nobody expected, and the reply to a one-digit probe in every framing.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from gateway.errors import ReplyFormatError
from gateway.protocol.catalog.settings import CMD_QJ, CMD_QSE
from gateway.protocol.framing import Series, checksum
from gateway.protocol.models import Command
from gateway.protocol.replies import (
    ReplyValue,
    decode_condition_bit,
    decode_motor_pair,
    decode_reply,
)
from gateway.protocol.spec import ReplyFormat

__all__ = [
    "ProbeReading",
    "decode_for",
    "fits_with_checksum",
    "fits_without_checksum",
    "probe_complete",
    "read_probe",
]

_HEX2 = re.compile(rb"[0-9A-F]{2}")


def decode_for(command: Command, data: str) -> ReplyValue:
    """The typed value of ``command``'s reply data (``ReplyFormatError`` if it does not fit)."""
    fmt = command.reply_format
    if fmt is ReplyFormat.CONDITION_BIT:
        return decode_condition_bit(data, int(command.params()["bit"]))
    if fmt is ReplyFormat.MOTOR_PAIR and command.spec in (CMD_QJ, CMD_QSE):
        return decode_motor_pair(data, max_setting=1)  # §10 QJ, QSE: 0 or 1 per motor
    return decode_reply(fmt, data)


def _fits(fmt: ReplyFormat, data: str) -> bool:
    try:
        decode_reply(fmt, data)
    except (ReplyFormatError, ValueError):
        return False
    return True


def fits_with_checksum(fmt: ReplyFormat, data: str) -> bool:
    """Whether ``data`` is a ``fmt`` reply followed by two hex digits: a checksum (SUM1)."""
    if len(data) <= 2 or not _HEX2.fullmatch(data[-2:].encode("ascii", "replace")):
        return False
    return _fits(fmt, data[:-2])


def fits_without_checksum(fmt: ReplyFormat, content: bytes) -> bool:
    """Whether ``content`` (a message without its CR) is a plain ``>$B#`` data reply to a
    ``fmt`` query, with no checksum (SUM0)."""
    if len(content) <= 3 or content[:1] != b">":
        return False
    return _fits(fmt, content[3:].decode("ascii", "replace"))


@dataclass(frozen=True)
class ProbeReading:
    """What a framing probe (``EE``, ``EL``, ``ER`` or ``SUM`` query) got back."""

    value: int | None  # the digit, None when no reply was read
    echo: bool = False  # the frame came back first (EE1)
    checksum: bool = False  # the reply carried a valid checksum (SUM1)
    not_accepted: bool = False  # '?': with SUM1 on, a frame without a checksum gets '?'


def _reply_pattern(series: Series, body: str) -> re.Pattern[bytes]:
    head = re.escape(series.mark + body.encode("ascii"))
    return re.compile(rb"(?P<gt>>?)(?P<line>" + head + rb"(?P<d>[0-9]))(?P<sum>[0-9A-F]{2})?\r")


def read_probe(raw: bytes, body: str, series: Series, sent: bytes) -> ProbeReading:
    """Interpret the bytes that answered a one-digit query ``sent``, whatever the framing."""
    echo = raw.startswith(sent)
    rest = raw[len(sent) :] if echo else raw
    if rest[:1] == b"?" or raw == b"?":
        return ProbeReading(None, not_accepted=True)
    match = _reply_pattern(series, body).fullmatch(rest)
    if match is None:
        return ProbeReading(None, echo=echo)
    digits = match["sum"]
    summed = False
    if digits is not None:
        content = (b">" if match["gt"] else b"") + match["line"]
        if checksum(content) != digits:
            return ProbeReading(None, echo=echo)  # corrupted: not trustworthy
        summed = True
    return ProbeReading(int(match["d"]), echo=echo, checksum=summed)


def probe_complete(raw: bytes, sent: bytes) -> bool:
    """Whether the probe's reply is in: a '?', or a CR after whatever echo came first."""
    if raw[:1] == b"?":
        return True
    rest = raw[len(sent) :] if raw.startswith(sent) else raw
    return rest.endswith(b"\r") and len(rest) > 1
