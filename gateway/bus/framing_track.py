"""Framing per controller (§10 EE, EL, ER, SUM): tracked when set through the gateway, detected
when a reply shows a framing the gateway did not expect.

The four switches change the reply bytes (echo, CR after '>', '>@', checksums) and, for SUM,
the command frames too. ``DW`` stores them in EEPROM (§10 DW), so a controller may come up with
any of them on; ``DL`` loads them. The tracker keeps what the scheduler believes per controller
and whether it is confirmed; hints from odd replies mark a controller *suspect*, and the
scheduler then reads EE, EL, ER and SUM back with ``read_probe``, which understands a query
reply in every framing: ``>$B#d`` CR, with a checksum (SUM1), or after the echo (EE1).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from gateway.errors import ReplyFormatError
from gateway.protocol.framing import Framing, Series, checksum
from gateway.protocol.models import Command
from gateway.protocol.replies import decode_reply
from gateway.protocol.reply_parser import (
    ChecksumMismatch,
    CommandRejected,
    DataReply,
    Garbled,
    ReplyEvent,
)

__all__ = [
    "FramingTracker",
    "ProbeReading",
    "hint_from_reply",
    "hint_from_stray",
    "probe_complete",
    "read_probe",
]

_HEX2 = re.compile(rb"[0-9A-F]{2}")


class FramingTracker:
    """What the scheduler believes of each controller's framing."""

    def __init__(self, initial: Framing) -> None:
        self._initial = initial
        self._framing: dict[str, Framing] = {}
        self._suspects: dict[str, str] = {}

    def get(self, body: str) -> Framing:
        """The framing to use with ``body`` now."""
        return self._framing.get(body, self._initial)

    def confirmed(self, body: str) -> bool:
        """True once set through the gateway or read back since the link came up."""
        return body in self._framing

    def set(self, body: str, framing: Framing) -> bool:
        """Record ``framing`` as confirmed; True when it differs from what was used before."""
        changed = self.get(body) != framing
        self._framing[body] = framing
        self._suspects.pop(body, None)
        return changed

    def forget(self, body: str | None = None) -> None:
        """Back to the assumed initial framing, unconfirmed (reconnect, power cycle, DL)."""
        if body is None:
            self._framing.clear()
            self._suspects.clear()
        else:
            self._framing.pop(body, None)

    def suspect(self, body: str, why: str) -> None:
        """A reply of ``body`` looked like another framing: read it back before the next use."""
        self._suspects.setdefault(body, why)

    def suspicion(self, body: str) -> str | None:
        """Why ``body``'s framing is in doubt, or None."""
        return self._suspects.get(body)

    def clear_suspicion(self, body: str) -> None:
        """The framing was read back (or could not be): stop doubting."""
        self._suspects.pop(body, None)


def hint_from_stray(event: ReplyEvent, framing: Framing) -> str | None:
    """Why a byte sequence after a reply suggests another framing, or None.

    A lone CR after a '>' is EL1 while EL0 was assumed (§10 EL).
    """
    if isinstance(event, Garbled) and event.raw == b"\r" and not framing.cr_after_ack:
        return "a CR followed '>' (EL1?)"
    return None


def hint_from_reply(
    event: ReplyEvent, command: Command, framing: Framing, *, printing: bool = False
) -> str | None:
    """Why the reply to ``command`` suggests the controller uses another framing, or None.

    * data that decodes once two trailing hex digits are removed: a checksum (SUM1, §10 SUM)
      that the gateway did not expect;
    * a checksum mismatch on a message that is a valid reply without a checksum: SUM0 while
      SUM1 was assumed. (A bit flipped by noise leaves no valid plain reply.)
    * '>@' to a general command while ER0 was assumed and a program may print (``printing``:
      the parser then waits for the byte after '>' and reads ER1's '>@' whole, §10 ER).
    """
    fmt = command.reply_format
    rejected = isinstance(event, CommandRejected) and not fmt.has_data
    if rejected and printing and not framing.error_mark:
        return "'>@' while ER0 was assumed (ER1?)"
    if isinstance(event, DataReply) and not framing.checksum and fmt.has_data:
        data = event.data
        if len(data) > 2 and _HEX2.fullmatch(data[-2:].encode("ascii", "replace")):
            try:
                decode_reply(fmt, data[:-2])
            except (ReplyFormatError, ValueError):
                return None
            return "a checksum after the data (SUM1?)"
    if isinstance(event, ChecksumMismatch) and framing.checksum:
        content = event.raw[:-1]
        if content == b">":
            return "'>' CR without a checksum (SUM0?)"
        if fmt.has_data and len(content) > 3 and content[:1] == b">":
            try:
                decode_reply(fmt, content[3:].decode("ascii", "replace"))
            except (ReplyFormatError, ValueError):
                return None
            return "a reply without a checksum (SUM0?)"
    return None


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
