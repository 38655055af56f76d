"""Simulated time: the clock, the actions it has due, and the record of what happened when.

Simulated time is float seconds of device time, running ``scale`` times faster than real time.

The simulator's logic never reads a clock; it takes ``now`` as an argument. Only the line
(``loop.SimLoop``) asks a ``SimClock`` what time it is when a host byte or a control request
arrives, and its ``Scheduler`` turns simulated deadlines into real delays for one asyncio
timer. One scale speeds up everything at once: wire times, motion, timers and EEPROM writes
(``--time-scale``), so tests run fast and benchmarks at real character timing. ``LineLog``
keeps what passed on the line, stamped with simulated time, for tests and the control
surface's ``trace``.
"""

from __future__ import annotations

import asyncio
import functools
import heapq
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

__all__ = ["LineLog", "LineRecord", "RecordKind", "Scheduler", "SimClock"]


class SimClock:
    """Simulated seconds since the clock was made, ``scale`` times faster than real time.

    ``time_fn`` is the real clock (monotonic seconds); the default is the one asyncio's event
    loop uses, so ``real_delay`` values are right for ``loop.call_later``. Tests can pass their
    own function and move it by hand.

    ``precise``: asyncio's timers wake late by up to a millisecond and more (epoll waits are
    rounded up to whole milliseconds), which at real time is a character at 9600 bps: a
    reply that reaches the host a millisecond late is a line that runs 5-10 % slow. With
    ``precise`` the scheduler's timer is a thread that sleeps until just before the time (the
    kernel's timers are good to some 0.1 ms) and hands the wake to the event loop, which
    yields (``call_soon``, no blocking) for the last fraction of a millisecond: the host gets
    each reply within some 0.05 ms of its time at almost no CPU. ``rc233-gateway sim`` and
    ``serve --simulate`` run precise; unit tests that move time by hand cannot (their
    ``time_fn`` is not the real clock).
    """

    def __init__(
        self,
        scale: float = 1.0,
        *,
        time_fn: Callable[[], float] = time.monotonic,
        start: float = 0.0,
        precise: bool = False,
    ) -> None:
        if not scale > 0:
            raise ValueError(f"time scale must be > 0, not {scale!r}")
        self.scale = float(scale)
        self.precise = precise
        self._time_fn = time_fn
        self._origin = time_fn()
        self._start = start

    def now(self) -> float:
        """The simulated time now."""
        return self._start + (self._time_fn() - self._origin) * self.scale

    def real_delay(self, until: float) -> float:
        """Real seconds from now until simulated time ``until`` (0 if it has passed)."""
        return max(0.0, (until - self.now()) / self.scale)

    def real_seconds(self, sim_seconds: float) -> float:
        """A simulated duration in real seconds."""
        return sim_seconds / self.scale

    def __repr__(self) -> str:
        return f"SimClock(scale={self.scale}, now={self.now():.6f})"


@dataclass(order=True)
class _Task:
    time: float
    seq: int
    action: Callable[[], None] = field(compare=False)


#: How much earlier than due a precise clock's thread hands the wake to the event loop; the
#: rest of the wait is spent yielding to the loop (``call_soon``).
_LEAD = 0.0003


class _WakeThread:
    """A thread that calls ``wake`` on the event loop at (just before) a real time.

    The event loop's own timers are rounded up to whole milliseconds; a condition variable's
    timed wait is not. The thread only ever hands ``wake`` to the loop
    (``call_soon_threadsafe``): everything the simulator does stays on the loop's thread.
    """

    def __init__(self, aio: asyncio.AbstractEventLoop) -> None:
        self._aio = aio
        self._due: float | None = None  # time.monotonic() to hand the wake over at
        self._wake: Callable[[], None] | None = None
        self._closed = False
        self._cond = threading.Condition()
        self._thread = threading.Thread(target=self._run, name="sim-clock", daemon=True)
        self._thread.start()

    def set(self, due: float, wake: Callable[[], None]) -> None:
        """Call ``wake`` on the loop at ``due`` (monotonic seconds), instead of any before."""
        with self._cond:
            self._due, self._wake = due, wake
            self._cond.notify()

    def close(self) -> None:
        """End the thread (it hands nothing over any more)."""
        with self._cond:
            self._closed = True
            self._cond.notify()

    def _run(self) -> None:
        with self._cond:
            while not self._closed:
                if self._due is None:
                    self._cond.wait()
                    continue
                left = self._due - time.monotonic()
                if left > 0:
                    self._cond.wait(left)
                    continue
                wake, self._due, self._wake = self._wake, None, None
                try:
                    if wake is not None:
                        self._aio.call_soon_threadsafe(wake)
                except RuntimeError:  # the loop closed under us
                    return


class Scheduler:
    """Actions due at simulated times, run in time order, each at its own time.

    Inside a running asyncio loop one timer, set ``clock.real_delay`` ahead, wakes it for the
    next action. Outside one (a test that moves time by hand) ``run_due`` does the work.
    ``time`` is the simulated time of the action running now, or of the last one; it never
    goes back, so the controllers always see time move forward.
    """

    def __init__(self, clock: SimClock) -> None:
        self.clock = clock
        self.time = clock.now()
        self._tasks: list[_Task] = []
        self._seq = 0
        self._timer: asyncio.TimerHandle | None = None
        self._spin: asyncio.Handle | None = None  # a precise clock's look again
        self._timer_at = float("inf")
        self._thread: _WakeThread | None = None  # the precise clock's timer
        self._armed = 0  # settings of the timer so far
        self.closed = False

    def now(self) -> float:
        """Simulated time now: the clock, but never before what has already been done."""
        self.time = max(self.time, self.clock.now())
        return self.time

    def at(self, time: float, action: Callable[..., None], *args: Any) -> None:
        """Run ``action(*args)`` at simulated ``time`` (call ``kick`` when done scheduling)."""
        self._seq += 1
        heapq.heappush(self._tasks, _Task(time, self._seq, functools.partial(action, *args)))

    @property
    def pending(self) -> int:
        """How many actions wait."""
        return len(self._tasks)

    def run_due(self, now: float) -> None:
        """Run every action due by ``now``, in time order (ties: in the order scheduled)."""
        while self._tasks and self._tasks[0].time <= now:
            task = heapq.heappop(self._tasks)
            self.time = max(self.time, task.time)
            task.action()
        self.time = max(self.time, now)

    def kick(self) -> None:
        """Set the timer for the first action (no-op outside an event loop)."""
        if not self._tasks or self.closed:
            return
        first = self._tasks[0].time
        if self._timer_at <= first:  # already set for it, or for something earlier
            return
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            return
        self._cancel()
        self._timer_at = first
        self._armed += 1  # a wake handed over for an earlier setting is stale
        delay = self.clock.real_delay(first)
        self._timer = loop.call_later(delay, self._wake, self._armed)
        if not self.clock.precise:
            return
        # Precise: the loop's own timer is on time while the loop is busy (its waits are not
        # rounded then) and the thread while it is idle (they are); the first to come wakes.
        if self._thread is None:
            self._thread = _WakeThread(loop)
        wake = functools.partial(self._wake, self._armed)
        self._thread.set(time.monotonic() + delay - _LEAD, wake)

    def _cancel(self) -> None:
        for handle in (self._timer, self._spin):
            if handle is not None:
                handle.cancel()
        self._timer = self._spin = None

    def _wake(self, armed: int) -> None:
        if armed != self._armed or self.closed:
            return
        if self.clock.precise and self._tasks and self._tasks[0].time > self.clock.now():
            # Handed over a little early on purpose: let the event loop run, and look again.
            if self._spin is not None:
                self._spin.cancel()
            self._spin = asyncio.get_running_loop().call_soon(self._wake, armed)
            return
        self._cancel()
        self._timer_at = float("inf")
        self.run_due(self.clock.now())
        self.kick()

    def close(self) -> None:
        """Stop the timer; nothing runs any more by itself."""
        self.closed = True
        self._cancel()
        if self._thread is not None:
            self._thread.close()
            self._thread = None


class RecordKind(StrEnum):
    """What a ``LineRecord`` reports."""

    HEARD = "heard"  # a host frame, program text or stray bytes, read off the line
    REPLY = "reply"  # a reply reached the host (data: the bytes as the host got them)
    NONE = "none"  # a frame gets no reply (note: why)
    LATER = "later"  # an unsolicited message reached the host
    ECHO = "echo"  # an inspection-mode echo reached the host
    LOST = "lost"  # host bytes, an unsolicited message or an echo was lost (note: why)
    FAULT = "fault"  # a fault was injected (note: its kind)
    POWER = "power"  # a controller was switched off or on
    CUT = "cut"  # the line was cut or restored
    BAUD = "baud"  # the line's rate changed
    HOST = "host"  # a host connected or disconnected (note)


@dataclass(frozen=True)
class LineRecord:
    """One thing that happened on the line, at simulated time ``time``."""

    seq: int
    time: float
    kind: RecordKind
    data: bytes = b""
    body: str | None = None
    ref: int = 0  # the number of the host frame this belongs to (1, 2, ...); 0 = none
    note: str = ""
    #: What reached the host (REPLY, LATER, ECHO): simulated seconds after ``time`` that the
    #: simulator handed it over, by its clock (how late its timer woke).
    late: float = 0.0


class LineLog:
    """The last ``size`` (up to twice that) records, numbered from 0; one can wait for one."""

    def __init__(self, size: int = 10_000) -> None:
        self._size = size
        self._records: list[LineRecord] = []  # numbered next_seq - len(_records) ... next_seq - 1
        self.next_seq = 0
        self._waiters: list[asyncio.Future[None]] = []

    def add(
        self,
        time: float,
        kind: RecordKind,
        data: bytes = b"",
        body: str | None = None,
        ref: int = 0,
        note: str = "",
        late: float = 0.0,
    ) -> LineRecord:
        """Append a record and wake the waiters."""
        record = LineRecord(self.next_seq, time, kind, data, body, ref, note, late)
        self.next_seq += 1
        self._records.append(record)
        if len(self._records) > 2 * self._size:
            del self._records[: -self._size]
        waiters, self._waiters = self._waiters, []
        for waiter in waiters:
            if not waiter.done():
                waiter.set_result(None)
        return record

    def since(self, seq: int) -> Iterator[LineRecord]:
        """The records numbered ``seq`` and later that are still kept."""
        first = self.next_seq - len(self._records)
        return iter(self._records[max(0, seq - first) :])

    async def wait_for(
        self, match: Callable[[LineRecord], bool], since: int, timeout: float
    ) -> LineRecord:
        """The first record from ``since`` on that ``match``es; TimeoutError after ``timeout``."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while True:
            for record in self.since(since):
                if match(record):
                    return record
            since = self.next_seq
            waiter = loop.create_future()
            self._waiters.append(waiter)
            await asyncio.wait_for(waiter, max(0.0, deadline - loop.time()))
