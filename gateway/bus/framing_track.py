"""Framing per controller (§10 EE, EL, ER, SUM): tracked when set through the gateway, detected
when a reply shows a framing the gateway did not expect.

The four switches change the reply bytes (echo, CR after '>', '>@', checksums) and, for SUM,
the command frames too. ``DW`` stores them in EEPROM (§10 DW), so a controller may come up with
any of them on; ``DL`` loads them. The tracker keeps what the scheduler believes per controller
and whether it is confirmed; hints from odd replies mark a controller *suspect*, and the
scheduler then reads EE, EL, ER and SUM back with ``read_probe`` (protocol/command_replies.py),
which understands a query reply in every framing: ``>$B#d`` CR, with a checksum (SUM1), or
after the echo (EE1).
"""

from __future__ import annotations

from gateway.protocol.command_replies import fits_with_checksum, fits_without_checksum
from gateway.protocol.framing import Framing
from gateway.protocol.models import Command
from gateway.protocol.reply_parser import (
    ChecksumMismatch,
    CommandRejected,
    DataReply,
    Garbled,
    ReplyEvent,
)

__all__ = [
    "FramingTracker",
    "hint_from_reply",
    "hint_from_stray",
]


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
        if fits_with_checksum(fmt, event.data):
            return "a checksum after the data (SUM1?)"
        return None
    if isinstance(event, ChecksumMismatch) and framing.checksum:
        content = event.raw[:-1]
        if content == b">":
            return "'>' CR without a checksum (SUM0?)"
        if fmt.has_data and fits_without_checksum(fmt, content):
            return "a reply without a checksum (SUM0?)"
    return None
