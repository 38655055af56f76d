"""The stop lane of one loop: the stops sent between two frames of the transaction in flight.

A stop outranks everything queued and does not wait for the transaction in flight to end: it
is the next frame on the wire (DESIGN invariants 8 and 12; docs/architecture.md, "A move, from
the router to the wire", step 5). Before each frame it writes, ``LineExchange.send`` asks the
lane whether a stop waits and lets it send the queued stops first; an EEPROM write's hold
(``eeprom_hold``) does the same while it keeps the line.

Who calls whom, one way:

* ``LoopScheduler`` builds the lane on its queue and hands it to the ``LineExchange`` and to
  the ``LoopLifecycle``; the lifecycle tells it, once, how one request runs (``run_by``: its
  ``execute``). The queue's put tells it a stop may head the queue now (``queued``).
* ``LineExchange.send`` -> ``StopLane.send_queued`` -> the ``run`` it was handed -> a
  ``TransactionRunner`` for the stop -> ``LineExchange.send`` of the stop's frame, which does
  not enter the lane again (``send_queued`` returns at once while it sends): stops go in the
  order they were queued.
* The exchange and the transaction know this lane only; nothing here names the lifecycle.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable

from gateway.bus.queue import Request, RequestQueue
from gateway.bus.requests import Priority

__all__ = ["StopLane"]

#: Runs one request to its end and answers its callers (``LoopLifecycle.execute``).
RunRequest = Callable[[Request], Awaitable[None]]


class StopLane:
    """Whether a stop waits for the next gap between frames, and sending those that do."""

    def __init__(self, queue: RequestQueue) -> None:
        self._queue = queue
        #: set while a stop heads the queue and waits for the next gap between frames
        self._waiting = asyncio.Event()
        self._run: RunRequest | None = None
        self._sending = False
        #: stops sent per controller from inside another transaction: one that a stop to its
        #: controller overtook sends nothing more that acts (``TransactionRunner``)
        self._sent: dict[str, int] = {}

    def run_by(self, run: RunRequest) -> None:
        """How a stop taken from the queue is run: the loop's ``execute`` (its owner's)."""
        self._run = run

    # ------------------------------------------------------------------ what the queue says

    def queued(self) -> None:
        """A request joined the queue: a stop at its head waits for the next gap."""
        if self._queue.head_priority() is Priority.STOP:
            self._waiting.set()

    def settle(self) -> None:
        """A request was taken from the queue: no stop waits unless one still heads it."""
        if self._queue.head_priority() is not Priority.STOP:
            self._waiting.clear()

    def clear(self) -> None:
        """No stop waits: the queue is empty, or its requests were failed."""
        self._waiting.clear()

    # ------------------------------------------------------------------ what a transaction asks

    def waiting(self) -> bool:
        """Whether a stop waits to go before the next frame."""
        return self._waiting.is_set()

    async def wait(self) -> None:
        """Until a stop waits (a hold that keeps the line wakes for it)."""
        await self._waiting.wait()

    def sent_to(self, body: str) -> int:
        """Stops sent so far to ``body`` from inside another transaction."""
        return self._sent.get(body, 0)

    async def send_queued(self) -> None:
        """Send the queued stops now, in their order, from inside the transaction that holds
        the line; at once when the lane is sending already (a stop's own frame)."""
        if self._sending or self._run is None:
            return
        self._sending = True
        try:
            while (request := self._queue.pop(only=Priority.STOP)) is not None:
                self._sent[request.body] = self._sent.get(request.body, 0) + 1
                await self._run(request)
            self._waiting.clear()
        finally:
            self._sending = False
