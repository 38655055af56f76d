"""Framing per controller (§10 EE, EL, ER, SUM): the scheduler's rules on it. It is learnt
when set through the gateway, and read back when a reply shows a framing the gateway did not
expect.

The four switches change the reply bytes (echo, CR after '>', '>@', checksums) and, for SUM,
the command frames too. ``DW`` stores them in EEPROM (§10 DW), so a controller may come up with
any of them on; ``DL`` loads them.

The framing the line uses has one home, the state cache (``ControllerState.framing``: set
through the gateway or read back since the link came up; None while not known, and the line
then assumes the loop's initial framing). The scheduler decides it alone and publishes what
it decides as ``FramingChanged`` (None: forgotten after a reconnect, a power cycle or ``DL``),
then reads it back from there, as it does the motor selection (``selection``). What stays here
is the scheduler's own work: hints from odd replies mark a controller *suspect*, and the
scheduler then reads EE, EL, ER and SUM back with ``read_probe``
(protocol/command_replies.py), which understands a query reply in every framing: ``>$B#d``
CR, with a checksum (SUM1), or after the echo (EE1).
"""

from __future__ import annotations

from collections.abc import Callable

from gateway.protocol.command_replies import fits_with_checksum, fits_without_checksum
from gateway.protocol.framing import BODY_NUMBERS, Framing
from gateway.protocol.models import Command
from gateway.protocol.reply_parser import (
    Accepted,
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

#: Where the framing is kept: ``known(body)``, the state cache's (None: not known).
KnownFraming = Callable[[str], Framing | None]
#: How a decision is told to it: ``publish(body, framing, detected)`` (a ``FramingChanged``).
PublishFraming = Callable[[str, Framing | None, bool], None]


class FramingTracker:
    """The scheduler's word on each controller's framing, kept in the state cache."""

    def __init__(self, initial: Framing, known: KnownFraming, publish: PublishFraming) -> None:
        self._initial = initial
        self._known = known
        self._publish = publish
        self._suspects: dict[str, str] = {}

    def get(self, body: str) -> Framing:
        """The framing to use with ``body`` now: the known one, else the assumed initial."""
        return self._known(body) or self._initial

    def confirmed(self, body: str) -> bool:
        """True once set through the gateway or read back since the link came up."""
        return self._known(body) is not None

    def set(self, body: str, framing: Framing, *, detected: bool = False) -> None:
        """Record ``framing`` as confirmed (published when it changed, and always when
        ``detected``: read back after a reply looked wrong)."""
        if detected or self._known(body) != framing:
            self._publish(body, framing, detected)
        self._suspects.pop(body, None)

    def forget(self, body: str | None = None) -> None:
        """Back to the assumed initial framing, unconfirmed (reconnect, power cycle, DL)."""
        if body is None:
            self._suspects.clear()
        for one in BODY_NUMBERS if body is None else (body,):
            if self._known(one) is not None:
                self._publish(one, None, False)

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
      the parser then waits for the byte after '>' and reads ER1's '>@' whole, §10 ER);
    * a bare '>' to a read that is never refused (allowed while moving: ``""``, ``9``, ``6``)
      while SUM1 was assumed: a controller on SUM0 read the checksum digits as part of the
      command and refused it (``$155`` CR is command ``55``). The one-character '>' carries no
      checksum (§10 SUM), so nothing else of such a reply tells.
    """
    fmt = command.reply_format
    if (
        isinstance(event, Accepted)
        and framing.checksum
        and fmt.has_data
        and command.spec.form_while_moving(command.form)
    ):
        return "a read answered with a bare '>' (SUM0?)"
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
