"""The queue of one loop: priorities, FIFO within a priority, deadlines, coalescing.

* Lower ``Priority`` first; within one priority, first come first served.
* A caller that goes away (its awaiting task cancelled) leaves the queue; a request nobody
  waits for any more is never sent. Except a stop: it goes out even when its caller went
  away (an HTTP client that disconnects must not leave the machine moving, DESIGN invariant 8).
* Every caller has a deadline: a request that cannot start in time fails at the deadline with
  ``DeadlineExpired`` (nothing was sent), not when it finally reaches the head. Stops have
  none: a stop never expires (DESIGN invariant 8).
* Identical read-only queries queued together (same controller, same motor, same commands, all
  ``QUERY`` forms that clear nothing) share one transaction: every caller gets its result. A
  caller of a higher priority lifts the shared request to its priority. Stops are never
  coalesced (they are not queries).
"""

from __future__ import annotations

import asyncio
import heapq
from collections.abc import Callable
from dataclasses import dataclass, field

from gateway.bus.requests import DeadlineExpired, Priority, TransactionResult
from gateway.protocol.models import Command
from gateway.protocol.program import Program
from gateway.protocol.spec import Effect

__all__ = ["Request", "RequestQueue", "Waiter", "coalesce_key"]

CoalesceKey = tuple[str, int | None, tuple[str, ...]]


def coalesce_key(
    body: str, commands: tuple[Command, ...], motor: int | None, program: Program | None
) -> CoalesceKey | None:
    """The key under which identical read-only transactions share one, or None."""
    if program is not None:
        return None
    for command in commands:
        if command.form.effect is not Effect.QUERY or command.form.clears_on_read:
            return None
    return (body, motor, tuple(c.wire() for c in commands))


@dataclass(eq=False)
class Waiter:
    """One caller waiting for a request's result."""

    future: asyncio.Future[TransactionResult]
    since: float
    timer: asyncio.TimerHandle | None = None


@dataclass(eq=False)
class Request:
    """One transaction to run, and everyone waiting for it."""

    body: str
    commands: tuple[Command, ...]
    motor: int | None
    priority: Priority
    program: Program | None = None
    key: CoalesceKey | None = None
    waiters: list[Waiter] = field(default_factory=list)
    started: bool = False

    @property
    def live(self) -> bool:
        """Not started, and someone still waits for it or it is a stop (sent regardless)."""
        if self.started:
            return False
        return self.priority is Priority.STOP or any(not w.future.done() for w in self.waiters)


class RequestQueue:
    """Requests by priority, then arrival; see the module's text."""

    def __init__(
        self,
        name: str,
        clock: Callable[[], float],
        on_put: Callable[[], None],
        *,
        aging: float | None = None,
    ) -> None:
        self._name = name
        self._clock = clock
        #: host seconds after which a waiting poll is lifted to operator priority (keeping
        #: its place in line): a steady stream of operator requests never starves the polls
        self._aging = aging
        self._on_put = on_put
        self._heap: list[tuple[int, int, Request]] = []
        self._seq = 0
        self._shared: dict[CoalesceKey, Request] = {}
        #: callers answered by another caller's identical transaction
        self.coalesced = 0
        self.expired = 0

    def __len__(self) -> int:
        """Requests waiting to start (alive)."""
        return sum(1 for p, _, r in self._heap if r.live and p == r.priority)

    def _push(self, request: Request) -> None:
        self._seq += 1
        heapq.heappush(self._heap, (int(request.priority), self._seq, request))

    def put(
        self,
        body: str,
        commands: tuple[Command, ...],
        *,
        priority: Priority,
        motor: int | None,
        program: Program | None,
        deadline: float | None,
    ) -> Waiter:
        """Queue a transaction (or join an identical queued one); the caller's ``Waiter``."""
        event_loop = asyncio.get_running_loop()
        waiter = Waiter(event_loop.create_future(), self._clock())
        key = coalesce_key(body, commands, motor, program)
        shared = self._shared.get(key) if key is not None else None
        if shared is not None and shared.live:
            shared.waiters.append(waiter)
            self.coalesced += 1
            if priority < shared.priority:
                shared.priority = priority
                self._push(shared)  # the old entry is skipped as stale
            request = shared
        else:
            request = Request(body, commands, motor, priority, program, key, [waiter])
            if key is not None:
                self._shared[key] = request
            self._push(request)
        if deadline is not None and request.priority is not Priority.STOP:
            waiter.timer = event_loop.call_later(deadline, self._expire, request, waiter, deadline)
        self._on_put()
        return waiter

    def _expire(self, request: Request, waiter: Waiter, deadline: float) -> None:
        if request.started or waiter.future.done():
            return
        self.expired += 1
        waiter.future.set_exception(DeadlineExpired(self._name, request.body, deadline, len(self)))
        self._forget_if_dead(request)

    def discard(self, waiter: Waiter) -> None:
        """The caller went away: stop waiting (the request goes when nobody waits)."""
        if waiter.timer is not None:
            waiter.timer.cancel()
        if not waiter.future.done():
            waiter.future.cancel()

    def _forget_if_dead(self, request: Request) -> None:
        if (
            not request.live
            and request.key is not None
            and self._shared.get(request.key) is request
        ):
            del self._shared[request.key]

    def _clean(self) -> None:
        """Drop stale heap entries from the top (started, abandoned, or lifted requests)."""
        while self._heap:
            priority, _, request = self._heap[0]
            if request.live and priority == request.priority:
                return
            heapq.heappop(self._heap)
            self._forget_if_dead(request)

    def _age(self) -> None:
        if self._aging is None:
            return
        old = self._clock() - self._aging
        for entry in list(self._heap):
            priority, _, request = entry
            if (
                priority == Priority.POLL == request.priority
                and request.live
                and min(w.since for w in request.waiters) <= old
            ):
                self._lift(entry)

    def _lift(self, entry: tuple[int, int, Request]) -> None:
        """A request passed over because it had to wait goes, once it may, before anything
        of its controller queued after it: a poll waiting for a motion to end is lifted to
        operator priority and keeps its place, so the next move does not starve it."""
        priority, seq, request = entry
        if priority > Priority.OPERATOR:
            request.priority = Priority.OPERATOR
            heapq.heappush(self._heap, (int(Priority.OPERATOR), seq, request))

    def head_priority(self) -> Priority | None:
        """The priority of the next request, None when the queue is empty."""
        self._clean()
        return Priority(self._heap[0][0]) if self._heap else None

    def pop(
        self, only: Priority | None = None, *, blocked: Callable[[Request], bool] | None = None
    ) -> Request | None:
        """The next live request (only of priority ``only`` if given), marked started.

        ``blocked(request)``: it cannot go now (it stays queued, bounded by its deadline) and
        the next one is taken instead.
        """
        self._age()
        self._clean()
        if not self._heap or (only is not None and self._heap[0][0] != only):
            return None
        entry: tuple[int, int, Request] | None = self._heap[0]
        if blocked is not None and blocked(self._heap[0][2]):
            ready = [
                e
                for e in sorted(self._heap)
                if e[2].live and e[0] == e[2].priority and (only is None or e[0] == only)
            ]
            entry = next((e for e in ready if not blocked(e[2])), None)
            for waiting in ready:
                if waiting is entry:
                    break
                self._lift(waiting)
            if entry is None:
                return None
            self._heap.remove(entry)
            heapq.heapify(self._heap)
        else:
            entry = heapq.heappop(self._heap)
        request = entry[2]
        request.started = True
        if request.key is not None and self._shared.get(request.key) is request:
            del self._shared[request.key]
        for waiter in request.waiters:
            if waiter.timer is not None:
                waiter.timer.cancel()
        return request

    def fail_all(self, make_error: Callable[[], Exception]) -> int:
        """Fail every queued caller (the loop went down or closed); how many."""
        failed = 0
        for _, _, request in self._heap:
            if request.started:
                continue
            request.started = True
            for waiter in request.waiters:
                if waiter.timer is not None:
                    waiter.timer.cancel()
                if not waiter.future.done():
                    waiter.future.set_exception(make_error())
                    failed += 1
        self._heap.clear()
        self._shared.clear()
        return failed
