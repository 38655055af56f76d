"""The poll plan's due times in order: the next job found without a walk over every job.

A loop of 15 controllers holds some 60 due times; picking the next job by walking all of them
cost every poll (and every exchange of an idle loop is a poll) a loop over the lot. Here every
due time that is set is also pushed on a heap ordered by time (the timeline); ``pick`` moves
the entries that have come due to a second heap ordered by urgency (rank, due time, body, job),
whose top is the job to run. Both heaps are cleaned lazily: an entry counts only while its
controller's job still has exactly that due time, so a job that ran, was rescheduled or was
dropped leaves its old entries behind, and they are thrown away when they reach a top.

The choice is the walk's: among the due jobs the least (rank, due, body); otherwise the
earliest due time. On a full tie (one controller holding two jobs of one rank with the same
due time, which the plan never does) the lower job goes first, where the walk took the one it
met first. ``tests/bus/test_due_queue.py`` runs both over seeded random plans.

The clock only goes forward on the scheduler (a monotonic clock); a pick at an earlier time
than the last one (a test's clock set back) rebuilds the heaps from the due times.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Mapping
from enum import IntEnum
from typing import Generic, TypeVar

__all__ = ["DueQueue", "DueTimes"]

J = TypeVar("J", bound=IntEnum)

#: the timeline may hold this many entries per live due time before it is rebuilt (entries
#: overwritten before they came due wait there until they do: a bound on memory)
_SLACK = 4


class DueTimes(Generic[J]):
    """One controller's jobs and their due times (host seconds); every time set is pushed."""

    __slots__ = ("_due", "_push", "body")

    def __init__(self, body: str, push: Callable[[float, str, J], None]) -> None:
        self.body = body
        self._push = push
        self._due: dict[J, float] = {}

    @property
    def view(self) -> Mapping[J, float]:
        """The due times, to read (set them with ``set``)."""
        return self._due

    def set(self, job: J, due: float) -> None:
        """Make ``job`` due at ``due``."""
        self._due[job] = due
        self._push(due, self.body, job)

    def take(self, job: J) -> float:
        """Remove ``job``; its due time."""
        return self._due.pop(job)

    def drop(self, job: J) -> None:
        """Remove ``job`` if it is there."""
        self._due.pop(job, None)

    def replace(self, due: Mapping[J, float]) -> None:
        """Exactly these jobs from now on."""
        self._due.clear()
        for job, when in due.items():
            self.set(job, when)


class DueQueue(Generic[J]):
    """The due times of every controller of one loop, by time and, once due, by urgency."""

    def __init__(self, rank: Callable[[J], int]) -> None:
        #: the urgency of a job among those due (lower first)
        self._rank = rank
        self.bodies: dict[str, DueTimes[J]] = {}
        self._timeline: list[tuple[float, str, J]] = []
        self._ready: list[tuple[int, float, str, J]] = []
        self._now = float("-inf")
        self._limit = 64  # entries in both heaps that make the next pick rebuild them

    def add(self, body: str) -> DueTimes[J]:
        """The due times of a new controller."""
        times: DueTimes[J] = DueTimes(body, self._push)
        self.bodies[body] = times
        return times

    def _push(self, due: float, body: str, job: J) -> None:
        heapq.heappush(self._timeline, (due, body, job))

    def rebuild(self) -> None:
        """Both heaps again from the due times (entries left behind are gone)."""
        self._timeline = [
            (due, body, job) for body, t in self.bodies.items() for job, due in t._due.items()
        ]
        heapq.heapify(self._timeline)
        self._ready = []
        self._limit = _SLACK * len(self._timeline) + 64

    def pick(self, now: float) -> tuple[str, J] | float:
        """The most urgent job due at ``now`` (its controller and job), or the time the next
        one is due (``inf``: none)."""
        if now < self._now or len(self._timeline) + len(self._ready) > self._limit:
            self.rebuild()
        self._now = now
        timeline, ready, bodies = self._timeline, self._ready, self.bodies
        while timeline and timeline[0][0] <= now:
            due, body, job = heapq.heappop(timeline)
            if bodies[body]._due.get(job) == due:
                heapq.heappush(ready, (self._rank(job), due, body, job))
        while ready:
            _, due, body, job = ready[0]
            if bodies[body]._due.get(job) == due:
                return body, job
            heapq.heappop(ready)
        while timeline:
            due, body, job = timeline[0]
            if bodies[body]._due.get(job) == due:
                return due
            heapq.heappop(timeline)
        return float("inf")
