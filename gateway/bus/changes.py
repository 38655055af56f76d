"""Numbered changes: the bounded history, the subscribers and how a slow one catches up.

Every change the state cache makes gets the next sequence number, is kept in a bounded
history and is published to subscribers (asyncio queues and plain callbacks). A subscriber
that fell behind asks for the changes since its last number, or takes a fresh snapshot when
the history no longer reaches back. ``ChangeLog`` is the half of ``StateCache`` that does
this; the cache supplies the snapshot.
"""

from __future__ import annotations

import asyncio
import logging
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Callable
from types import MappingProxyType
from typing import Any

from gateway.bus.state_types import Change, Snapshot

__all__ = ["ChangeLog", "FellBehind", "Subscription"]

log = logging.getLogger("gateway.bus")


class FellBehind(Exception):
    """A subscription dropped changes because its queue was full; call ``resync``."""


class Subscription:
    """The changes of a ``StateCache`` as an asyncio queue (``async for change in sub``).

    A reader that is too slow does not slow the gateway: once the queue is full further
    changes are dropped, and after the queued ones ``get`` raises ``FellBehind``; ``resync``
    then returns what was missed (the changes, or a snapshot when the history no longer
    reaches back) and delivery goes on from there.
    """

    def __init__(self, cache: ChangeLog, maxsize: int) -> None:
        self._cache = cache
        self._queue: asyncio.Queue[Change] = asyncio.Queue(maxsize)
        self.last_seq = cache.seq  # the last change delivered (or caught up with)
        self.behind = False

    def _put(self, change: Change) -> None:
        if self.behind:
            return
        try:
            self._queue.put_nowait(change)
        except asyncio.QueueFull:
            self.behind = True

    async def get(self) -> Change:
        """The next change; ``FellBehind`` once the queue overflowed and is drained."""
        if self.behind and self._queue.empty():
            raise FellBehind(f"changes after {self.last_seq} were dropped")
        change = await self._queue.get()
        self.last_seq = change.seq
        return change

    def resync(self) -> list[Change] | Snapshot:
        """What was missed since ``last_seq``; delivery resumes after it."""
        missed: list[Change] | Snapshot | None = self._cache.changes_since(self.last_seq)
        if missed is None:
            missed = self._cache.snapshot()
        while not self._queue.empty():
            self._queue.get_nowait()
        self.behind = False
        self.last_seq = self._cache.seq
        return missed

    def close(self) -> None:
        """Stop receiving changes."""
        self._cache._subscriptions.discard(self)

    def __aiter__(self) -> Subscription:
        return self

    async def __anext__(self) -> Change:
        return await self.get()


class ChangeLog(ABC):
    """Numbers, keeps and publishes changes; read by change number, queue or callback."""

    def __init__(self, history: int) -> None:
        self._seq = 0
        self._history: deque[Change] = deque(maxlen=history)
        self._subscriptions: set[Subscription] = set()
        self._callbacks: list[Callable[[Change], None]] = []

    @property
    def seq(self) -> int:
        """The number of the latest change (0: none yet)."""
        return self._seq

    @abstractmethod
    def snapshot(self) -> Snapshot:
        """Everything, with the sequence number to ask ``changes_since`` from next."""

    def changes_since(self, seq: int) -> list[Change] | None:
        """The changes after ``seq``; None when the history no longer reaches back (resync
        with ``snapshot``)."""
        if seq >= self._seq:
            return []
        oldest = self._history[0].seq if self._history else self._seq + 1
        if seq + 1 < oldest:
            return None
        return [c for c in self._history if c.seq > seq]

    def subscribe(self, maxsize: int = 1000) -> Subscription:
        """A queue of every change from now on (see ``Subscription`` for falling behind)."""
        sub = Subscription(self, maxsize)
        self._subscriptions.add(sub)
        return sub

    def listen(self, callback: Callable[[Change], None]) -> Callable[[], None]:
        """Call ``callback`` with every change (synchronously); returns the unsubscribe."""
        self._callbacks.append(callback)
        return lambda: self._callbacks.remove(callback) if callback in self._callbacks else None

    def _emit(self, now: float, loop: str, body: str | None, motor: int | None, **v: Any) -> None:
        self._seq += 1
        change = Change(self._seq, now, loop, body, motor, MappingProxyType(v))
        self._history.append(change)
        for sub in list(self._subscriptions):
            sub._put(change)
        for callback in list(self._callbacks):
            try:
                callback(change)
            except Exception:  # one bad listener must not stop the others
                log.exception("state listener %r failed", callback)
