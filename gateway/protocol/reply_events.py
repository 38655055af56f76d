"""What the reply parser reports: one event per message a controller sent (§9-2, §10, §11-3).

Every event carries the bytes it came from and ``is_reply``: True when it answers the pending
command (good or bad). ``Expectation`` is what the host waits for after sending a command.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from gateway.protocol.framing import Framing, Series

__all__ = [
    "Accepted",
    "ChecksumMismatch",
    "CommandRejected",
    "DataReply",
    "Expectation",
    "Garbled",
    "NotAccepted",
    "ReplyEvent",
    "Unsolicited",
    "UnsolicitedKind",
    "device_report",
    "program_output",
]


class UnsolicitedKind(StrEnum):
    """What an unsolicited message is (§10 AW/DW/IW/EE///, §10 T, §11-3, §12)."""

    EEPROM_DONE = "eeprom_done"  # '$B#*' CR: the EEPROM write or erase has finished
    TIMER_UP = "timer_up"  # '$B#T' CR: the timer of T{time} ran out
    PROGRAM_OUTPUT = "program_output"  # a user program's query output, /CO, /CC, or '@'


@dataclass(frozen=True, kw_only=True)
class ReplyEvent:
    """Base of the parser's events."""

    raw: bytes
    #: True when the event answers the pending command; it then ends the expectation
    is_reply: bool = False


@dataclass(frozen=True, kw_only=True)
class Accepted(ReplyEvent):
    """'>' (or '>' CR, '>3E' CR, the bare echo): the command was received, not "it was valid"."""


@dataclass(frozen=True, kw_only=True)
class CommandRejected(ReplyEvent):
    """'>@' (ER1): the command caused a command error."""


@dataclass(frozen=True, kw_only=True)
class NotAccepted(ReplyEvent):
    """'?': communication abnormality, or a command checksum the device found wrong."""


@dataclass(frozen=True, kw_only=True)
class DataReply(ReplyEvent):
    """A query reply; ``data`` is the text between mark B# and CR, checksum removed."""

    body: str
    data: str


@dataclass(frozen=True, kw_only=True)
class ChecksumMismatch(ReplyEvent):
    """A CR-terminated message whose checksum is wrong: its content is not trustworthy."""


@dataclass(frozen=True, kw_only=True)
class Unsolicited(ReplyEvent):
    """A message no command asked for; ``series``/``body`` are None for '>text' and '@'."""

    kind: UnsolicitedKind
    series: Series | None
    body: str | None
    data: str  # the text after mark B# (or after '>' for /CO), checksum removed


@dataclass(frozen=True, kw_only=True)
class Garbled(ReplyEvent):
    """Bytes that fit no rule, a message cut short, or an echo that differs from the command."""


@dataclass(frozen=True)
class Expectation:
    """The reply the parser waits for."""

    body: str
    sent: bytes
    has_data: bool
    framing: Framing
    series: Series

    def is_from(self, series: Series, body: str) -> bool:
        """Whether a message of ``series`` and ``body`` comes from the addressed controller."""
        return series is self.series and body == self.body


def program_output(raw: bytes, series: Series | None, body: str | None, data: str) -> Unsolicited:
    """A user program's printed line (§12 /CO, /CC, query output), or its lone '@' (§10 ER)."""
    return Unsolicited(
        raw=raw, kind=UnsolicitedKind.PROGRAM_OUTPUT, series=series, body=body, data=data
    )


def device_report(raw: bytes, series: Series, body: str, rest: bytes) -> Unsolicited:
    """``$B#*`` (an EEPROM write or erase ended, §10 AW/DW/IW/EE///) or ``$B#T`` (§10 T)."""
    kind = UnsolicitedKind.EEPROM_DONE if rest == b"*" else UnsolicitedKind.TIMER_UP
    return Unsolicited(raw=raw, kind=kind, series=series, body=body, data=rest.decode())
