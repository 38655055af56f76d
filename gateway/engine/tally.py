"""The poller's transactions of controllers nobody follows, carried to the client in bulk.

An idle poll changes nothing the API process shows: the state reaches it as changes, and its
reply events stay in the worker unless an operation follows the controller. What is left is
its ``TransactionDone``, read on the far side only for figures (the metrics' durations and
outcomes, the counters, the line's busy time). ``Tally`` keeps those of one loop as
``TransactionTally`` rows and hands them on as one ``TransactionsTallied`` a period (one
message a second instead of one an exchange), or at once before any other event of the loop
crosses, so that the client reads every loop's events in the order they happened and each
row's counter gains add up to the counters the next event carries.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import TransactionDone, TransactionsTallied, TransactionTally

__all__ = ["TALLY_PERIOD", "Tally"]

#: real seconds a tally is held at most: the metrics and counters lag by no more than this
TALLY_PERIOD = 1.0


class Tally:
    """The untold transactions of one loop; ``flush`` sends them as one event."""

    def __init__(
        self,
        loop: str,
        send: Callable[[TransactionsTallied], None],
        counters: CountersSnapshot,
        *,
        period: float = TALLY_PERIOD,
    ) -> None:
        self.loop = loop
        self._send = send
        self.period = period
        self._rows: list[TransactionTally] = []
        #: the loop's counters after the last transaction seen (at first: as the client got
        #: them in its snapshot), from which each row's gains are counted
        self._last = counters
        self._time = 0.0
        self._timer: asyncio.TimerHandle | None = None

    def seen(self, event: TransactionDone) -> None:
        """A transaction that crosses on its own: what it adds is counted from here on."""
        self._last = event.counters

    def add(self, event: TransactionDone) -> None:
        """Keep ``event`` for the next flush (within ``period``)."""
        counters, last = event.counters, self._last
        self._rows.append(
            TransactionTally(
                event.body,
                event.priority,
                event.outcome,
                event.duration,
                event.exchanges,
                counters.timeouts - last.timeouts,
                counters.retries - last.retries,
            )
        )
        self._last, self._time = counters, event.time
        if self._timer is None:
            self._timer = asyncio.get_running_loop().call_later(self.period, self.flush)

    def flush(self) -> None:
        """Send what is kept, if anything, as one ``TransactionsTallied``."""
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if not self._rows:
            return
        rows, self._rows = tuple(self._rows), []
        self._send(
            TransactionsTallied(loop=self.loop, time=self._time, tallies=rows, counters=self._last)
        )

    def close(self) -> None:
        """Drop what is kept and the timer (the client went away)."""
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        self._rows.clear()
