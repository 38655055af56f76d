"""How late this line's replies have come: the silence a resync waits for grows with it.

The silence that brings the line back in step after a lost reply is, at the least, the
longest reply any controller can send plus the turnaround (``Timing.resync_quiet``). A line
shows its own lateness on top (a device server's buffers, a USB adapter, a busy host): each
reply that completes after its time-out, and each reply-shaped message that comes when no
exchange awaits it soon after one, says how long after a time-out a reply can still come.
The resync then waits ``MARGIN`` times the longest such lateness seen, up to ``MOST`` times
the longest reply's silence (a stray that noise made of a reply must not stall the line); every
resync that stays silent lets the figure decay, so a line that was late once does not pay for
it for ever. Host seconds throughout (the event loop's clock).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["CAP", "DECAY", "MARGIN", "MOST", "Lateness"]

#: The resync waits this many times the longest lateness seen.
MARGIN = 1.5
#: No lateness beyond this is learnt (host seconds): a message that late is no reply.
CAP = 1.0
#: The silence is never more than this many times the longest reply's (``Timing.resync_quiet``).
MOST = 3.0
#: Each silent resync keeps this share of the lateness learnt (some 35 to halve it).
DECAY = 0.98


@dataclass
class Lateness:
    """The longest lateness past a time-out this line has shown (decaying), in host seconds."""

    seen: float = 0.0
    #: the event loop's time of the latest time-out (None: none yet)
    since: float | None = None

    def timed_out(self, now: float) -> None:
        """An exchange has just timed out."""
        self.since = now

    def arrived(self, now: float) -> None:
        """A reply came late now (after a time-out, or with no exchange awaiting it)."""
        if self.since is None:
            return
        late = now - self.since
        if 0.0 <= late <= CAP:
            self.seen = max(self.seen, late)

    def silent(self) -> None:
        """A resync found the line silent: nothing late came."""
        self.seen *= DECAY

    def quiet(self, base: float) -> float:
        """The silence to wait for: ``base`` (the longest reply), or more on a late line."""
        return max(base, min(MARGIN * self.seen, MOST * base))
