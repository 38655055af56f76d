"""The worker's end: the schedulers and state cache of its loops, served over two channels.

``LineWorker(schedulers, state).serve(requests, stops)`` sends a snapshot of the state cache
and every loop's link, then every change of the cache (numbered: the client notices a gap
and asks again) and every bus event; it runs each request as a task of its own (the
scheduler orders them by priority, as it does for callers in its own process) and answers
on the channel the request came on. The stop channel is read by a task of its own, so a
stop reaches the scheduler as soon as its bytes are in, whatever the request channel holds.

``serve`` returns when the request channel closes (the client went away); the loops keep
running, and a client that connects again gets a fresh snapshot.

Reply events (``ReplyObserved``: one or more a poll) are relayed for every controller until
the client says which it follows (``FOLLOW``: those an operation watches; the state reaches
the client as changes). Once it has, the poller's transactions of the controllers it does not
follow cross in bulk (``Tally``: one ``TransactionsTallied`` a second, or sooner before any
other event of the loop), so that an idle poll that changed nothing sends nothing at once.

The time of each controller's and axis's latest reply follows every ``FRESH_SECONDS``
(``FRESH``: those that moved), since a poll that changed nothing publishes no change; the
mirror moves its records' ``updated`` silently, so a reading's age is the worker's.

The rest of what the API process reads of a scheduler follows it too: the line's rate and
adapter report with every link event (``LINE``, before the event), the trace's records while
the client has it switched on (``TRACED``), and the client's acknowledges of latched errors
and trace switches come as requests without an answer.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable, Mapping
from typing import Any

from gateway.bus.events import (
    BusEvent,
    LinkDown,
    LinkUp,
    ReplyObserved,
    TransactionDone,
)
from gateway.bus.poller import Poller
from gateway.bus.requests import Priority, TransactionError
from gateway.bus.scheduler import LoopScheduler
from gateway.bus.state import StateCache
from gateway.bus.trace import FrameDirection, TraceRecord
from gateway.engine.tally import Tally
from gateway.engine.wire import Channel, Kind, encode, encode_error, read_message

__all__ = ["LineWorker"]

log = logging.getLogger("gateway.engine")

#: Real seconds between two sendings of the replies' times (``FRESH``): a reading's age as
#: the API process tells it is at most this late.
FRESH_SECONDS = 1.0


class LineWorker:
    """The loops of one worker, served to one client at a time."""

    def __init__(
        self,
        schedulers: Mapping[str, LoopScheduler],
        state: StateCache,
        pollers: Mapping[str, Poller] | None = None,
    ) -> None:
        self.schedulers = dict(schedulers)
        self.state = state
        self.pollers = dict(pollers or {})
        self._tasks: set[asyncio.Task[None]] = set()
        #: the controllers whose reply events the client reads (None: every controller's)
        self.followed: frozenset[tuple[str, str]] | None = None

    def links(self) -> dict[str, tuple[Any, ...]]:
        """Every loop's link state, cause, queue depth, counters and adapter report, as the
        snapshot carries them."""
        return {name: _link(s) for name, s in self.schedulers.items()}

    async def serve(self, requests: Channel, stops: Channel) -> None:
        """Serve one client until it closes the request channel."""
        reader, writer = requests
        stop_reader, stop_writer = stops

        def send(message: tuple[Any, ...]) -> None:
            if not writer.is_closing():
                writer.write(encode(message))

        self.followed = None  # a new client reads every reply until it says otherwise
        send((Kind.SNAPSHOT, self.state.snapshot(), self.links()))
        unsubscribe: list[Callable[[], None]] = [
            self.state.changes.subscribe(lambda change: send((Kind.CHANGE, change)))
        ]
        for name, scheduler in self.schedulers.items():
            relay, tally = self._relay(name, scheduler, send)
            unsubscribe.append(scheduler.events.subscribe(relay))
            unsubscribe.append(tally.close)
            unsubscribe.append(_relay_trace(name, scheduler, send))
        stop_task = asyncio.create_task(self._read_stops(stop_reader, stop_writer))
        fresh_task = asyncio.create_task(self._send_fresh(send))
        try:
            while (message := await read_message(reader)) is not None:
                if message[0] == Kind.RESYNC:
                    send((Kind.SNAPSHOT, self.state.snapshot(), self.links()))
                elif message[0] in (Kind.SUBMIT, Kind.UPLOAD, Kind.POLLING):
                    self._spawn(self._submit(message, send))
                elif message[0] == Kind.REOPEN:
                    self._scheduler(message[1]).reopen_at(message[2])
                elif message[0] == Kind.ACKNOWLEDGE:
                    _, loop, body, motor, kinds = message
                    now = self._scheduler(loop).clock()
                    self.state.acknowledge(loop, body, now, motor=motor, kinds=kinds)
                elif message[0] == Kind.FOLLOW:
                    self.followed = frozenset(message[1])
                elif message[0] == Kind.TRACE:
                    _trace_switches(self._scheduler(message[1]), *message[2:])
                else:
                    log.error("line worker: unknown request %r", message[0])
        finally:
            for undo in unsubscribe:
                undo()
            stop_task.cancel()
            fresh_task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await stop_task
            with contextlib.suppress(asyncio.CancelledError):
                await fresh_task
            for task in list(self._tasks):
                task.cancel()
            writer.close()
            stop_writer.close()

    def _relay(
        self, name: str, scheduler: LoopScheduler, send: Callable[[tuple[Any, ...]], None]
    ) -> tuple[Callable[[BusEvent], None], Tally]:
        def tell(event: BusEvent) -> None:
            # the link as of the event: the client's proxy reads it without asking
            send((Kind.EVENT, name, event, scheduler.state.value, scheduler.cause,
                  scheduler.queue_depth))  # fmt: skip

        tally = Tally(name, tell, scheduler.snapshot())

        def relay(event: BusEvent) -> None:
            followed = self.followed
            if followed is not None:
                if isinstance(event, ReplyObserved) and (event.loop, event.body) not in followed:
                    return  # what it taught crosses as changes; nobody there reads the reply
                if (
                    isinstance(event, TransactionDone)
                    and event.priority is Priority.POLL
                    and (event.loop, event.body) not in followed
                ):
                    tally.add(event)  # figures only: they cross within the tally's period
                    return
            tally.flush()  # what ended before this event crosses before it
            if isinstance(event, TransactionDone):
                tally.seen(event)
            if isinstance(event, LinkUp | LinkDown):  # the line as (re)opened, before its news
                send((Kind.LINE, name, scheduler.timing.baud, scheduler.transport.adapter))
            tell(event)

        return relay, tally

    async def _send_fresh(self, send: Callable[[tuple[Any, ...]], None]) -> None:
        """Every ``FRESH_SECONDS``, the times of the latest replies that moved since the last
        sending (``FRESH``): a poll that changes nothing publishes nothing, and yet the
        client's views must say how old their reading is (``updated``, the ``Age`` header,
        a metric's timestamp) as the cache of one process does, to within that period."""
        sent: dict[Any, float] = {}
        while True:
            await asyncio.sleep(FRESH_SECONDS)
            moved = {k: t for k, t in self.state.latest_updates().items() if sent.get(k) != t}
            if moved:
                sent.update(moved)
                send((Kind.FRESH, moved))

    async def _read_stops(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        def send(message: tuple[Any, ...]) -> None:
            if not writer.is_closing():
                writer.write(encode(message))

        while (message := await read_message(reader)) is not None:
            if message[0] == Kind.STOP:
                self._spawn(self._stop(message, send))
            else:
                log.error("line worker: %r on the stop channel", message[0])

    def _spawn(self, work: Any) -> None:
        task = asyncio.create_task(work)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    def _scheduler(self, loop: str) -> LoopScheduler:
        scheduler = self.schedulers.get(loop)
        if scheduler is None:
            raise TransactionError(f"loop {loop!r} is not served by this worker")
        return scheduler

    async def _submit(
        self, message: tuple[Any, ...], send: Callable[[tuple[Any, ...]], None]
    ) -> None:
        rid, loop = message[1], message[2]
        result: object
        try:
            scheduler = self._scheduler(loop)
            if message[0] == Kind.SUBMIT:
                _, _, _, body, commands, priority, motor, deadline = message
                result = await scheduler.submit(
                    body, commands, priority=priority, motor=motor, deadline=deadline
                )
            elif message[0] == Kind.UPLOAD:
                _, _, _, body, program, priority, deadline = message
                result = await scheduler.upload_program(
                    body, program, priority=priority, deadline=deadline
                )
            else:
                await self._polling(loop, on=message[3])
                result = None
        except Exception as exc:
            send((Kind.ERROR, rid, encode_error(exc)))
        else:
            send((Kind.RESULT, rid, result))

    async def _polling(self, loop: str, *, on: bool) -> None:
        poller = self.pollers.get(loop)
        if poller is None:
            raise TransactionError(f"loop {loop!r} has no poller in this worker")
        if on:
            poller.start()
        else:
            await poller.stop()

    async def _stop(
        self, message: tuple[Any, ...], send: Callable[[tuple[Any, ...]], None]
    ) -> None:
        _, rid, loop, body, command = message
        try:
            result = await self._scheduler(loop).stop(body, command)
        except Exception as exc:
            send((Kind.ERROR, rid, encode_error(exc)))
        else:
            send((Kind.RESULT, rid, result))


def _link(s: LoopScheduler) -> tuple[Any, ...]:
    return (s.state.value, s.cause, s.queue_depth, s.snapshot(), s.transport.adapter,
            s.timing.baud)  # fmt: skip


def _trace_switches(
    scheduler: LoopScheduler, everything: bool, bodies: tuple[str, ...], hex_mode: bool, clear: bool
) -> None:
    trace = scheduler.trace
    trace.enable(everything, hex_mode=hex_mode)
    for body in set(trace.bodies) - set(bodies):
        trace.enable_body(body, False)
    for body in bodies:
        trace.enable_body(body, True)
    if clear:
        trace.clear()


def _relay_trace(
    name: str, scheduler: LoopScheduler, send: Callable[[tuple[Any, ...]], None]
) -> Callable[[], None]:
    """Send each record the loop's trace keeps to the client, until the returned undo.

    The line's parts hold the trace object itself, so its ``add`` is wrapped on the instance;
    the exchange path asks ``trace.on`` before it builds a record, so an untraced loop costs
    nothing here."""
    trace = scheduler.trace
    original = trace.add

    def add(
        time: float, direction: FrameDirection, body: str | None, data: bytes, note: str = ""
    ) -> None:
        original(time, direction, body, data, note)
        if trace.wants(body):
            send((Kind.TRACED, name, TraceRecord(time, direction, body, bytes(data), note)))

    trace.add = add  # type: ignore[method-assign]

    def undo() -> None:
        del trace.add  # the class's own again

    return undo
