"""Unsolicited bytes that are not what they look like: a reply in an unexpected framing.

A controller whose framing the gateway does not know yet (EE1, ER1: §10 EE, §10 ER) answers in
shapes the parser takes for a program's output. Such bytes are a framing hint for the
scheduler's ``FramingTracker``, never published as program output.
"""

from __future__ import annotations

from gateway.bus.counters import Counters
from gateway.bus.framing_track import FramingTracker, hint_from_stray
from gateway.bus.link import Link
from gateway.protocol.reply_parser import ReplyEvent, Unsolicited

__all__ = ["framing_artefact", "stray_hint"]


def stray_hint(event: ReplyEvent, body: str | None, tracker: FramingTracker) -> None:
    """A reply nobody awaited, after ``body``'s: what it suggests of that framing."""
    if body is None:
        return
    why = hint_from_stray(event, tracker.get(body))
    if why is not None:
        tracker.suspect(body, why)


def framing_artefact(
    event: Unsolicited, tracker: FramingTracker, link: Link, counters: Counters
) -> bool:
    """Whether "program output" is a reply in a framing the gateway did not expect (the
    tracker is told what it suggests)."""
    body = event.body
    if link.is_echo(event.raw):
        # Our own frame came back: the controller has EE1 on (§10 EE).
        if body is not None:
            tracker.suspect(body, "the frame came back (EE1?)")
        return True
    if body is not None and body == link.pending_body and tracker.suspicion(body):
        counters.garbled += 1  # the data part that followed that echo
        return True
    last = link.last_body
    # '>@' of ER1 read as '>' then '@' while ER0 was assumed (§10 ER); a running
    # program's '@' comes from a controller whose framing was read back.
    if (
        event.raw == b"@"
        and last is not None
        and not tracker.confirmed(last)
        and not tracker.get(last).error_mark
    ):
        tracker.suspect(last, "'@' after '>' (ER1?)")
        return True
    return False
