"""The running side of a loop's scheduler: connect, serve the queue, go down, reconnect.

One task runs the queue: the highest priority first, FIFO within a priority, one transaction
at a time; a stop before the next frame, inside a transaction too (DESIGN invariant 8,
``LoopCore.send``). When the transport raises ``TransportClosed``, or ``timeouts_to_down``
time-outs in a row bring no byte, the loop goes DOWN: queued requests fail at once with
``LoopDown`` (with a retry-after hint) and the port is reopened with backoff (doubling, with
jitter). Once back, the selection and framing caches are dropped and ``LinkUp`` is published:
the state layer re-reads the controllers from the devices. ``scheduler`` adds the callers' side.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import time
from collections.abc import Callable
from enum import StrEnum

from gateway.bus.config import LoopConfig
from gateway.bus.counters import Counters, CountersSnapshot
from gateway.bus.events import (
    BusEvent,
    EventBus,
    LinkDown,
    LinkUp,
    TransactionDone,
    UnsolicitedMessage,
)
from gateway.bus.exchange import LoopCore
from gateway.bus.link import Link, LinkLost
from gateway.bus.messages import framing_artefact, stray_hint
from gateway.bus.programs_seen import ProgramsSeen
from gateway.bus.queue import Request, RequestQueue
from gateway.bus.requests import LoopDown, Priority, TransactionResult
from gateway.bus.selection import needs_selection
from gateway.bus.state import StateCache
from gateway.bus.timing import Timing
from gateway.bus.trace import LineTrace
from gateway.bus.transaction import TransactionRunner
from gateway.protocol.framing import BODY_NUMBERS
from gateway.protocol.reply_parser import ReplyEvent, Unsolicited, UnsolicitedKind
from gateway.transport.base import Transport, TransportClosed
from gateway.transport.factory import Backoff

__all__ = ["LinkState", "LoopLifecycle"]

log = logging.getLogger("gateway.bus")


class LinkState(StrEnum):
    """Where the loop's line is."""

    CONNECTING = "connecting"
    UP = "up"
    DOWN = "down"
    CLOSED = "closed"


class LoopLifecycle:
    """The queue, the link and the task that serves one from the other."""

    def __init__(
        self,
        transport: Transport,
        config: LoopConfig | None = None,
        *,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.config = config = config or LoopConfig()
        self.name = config.name
        self.transport = transport
        self.clock = clock
        self.counters = Counters()
        self.events: EventBus[BusEvent] = EventBus()
        self.trace = LineTrace(config.trace_size)
        self.timing = Timing(
            baud=config.baud or transport.baud,
            scale=config.time_scale,
            turnaround=config.turnaround,
            host_latency=config.host_latency,
            quiet_chars=config.quiet_chars,
        )
        self._wake = asyncio.Event()
        self._programs = ProgramsSeen()
        self.events.subscribe(self._programs.handle, urgent=True)  # the parser's `printing`
        self._link = Link(
            transport,
            self.timing,
            self.counters,
            self.trace,
            on_unsolicited=self._unsolicited,
            on_stray=self._stray,
            on_lost=self._wake.set,
            clock=clock,
            programs=self._programs,
        )
        self._core = LoopCore(
            self.name,
            config,
            self.timing,
            self._link,
            self.counters,
            self.events,
            clock,
            serve_stops=self._serve_stops,
        )
        self._queue = RequestQueue(self.name, clock, self._queued, aging=config.poll_aging_real)
        self.state = LinkState.CONNECTING
        self.cause = "not connected yet"
        first = max(1e-6, min(config.reconnect_initial_real, config.reconnect_max_real))
        self._backoff = Backoff(first, max(first, config.reconnect_max_real))  # with jitter
        self._delay = self._backoff.next_delay()  # the next wait before reopening
        self._retry_at: float | None = None
        self._task: asyncio.Task[None] | None = None
        self._first_attempt = asyncio.Event()
        self._idle = asyncio.Event()  # set while no transaction is in flight (shutdown waits)
        self._idle.set()
        #: the state cache the scheduler feeds first and reads: its own until ``use_state``
        self.state_cache: StateCache = self._core.state
        self._unfeed = self._feed(self.state_cache)

    def snapshot(self) -> CountersSnapshot:
        """The loop's counters now."""
        self.counters.coalesced = self._queue.coalesced
        self.counters.expired = self._queue.expired
        return self.counters.snapshot()

    def _queued(self) -> None:
        if self._queue.head_priority() is Priority.STOP:  # before any frame of a transaction
            self._core.stop_waiting.set()
        self._wake.set()

    def down_error(self) -> LoopDown:
        """The error of a request refused because the loop is not up (with its retry hint)."""
        return self._down_error()

    def reopen_at(self, baud: int) -> None:
        """Reopen the port at ``baud`` (the controllers were moved there with ``ES``, §10 ES):
        the timing and the transport take the new rate, then the link is lost on purpose and
        the run loop reconnects as after any loss (one LinkDown, queued requests fail with
        LoopDown; the controllers that answered before are probed at the new rate)."""
        timing = dataclasses.replace(self.timing, baud=baud)
        self.timing = self._link.timing = self._core.timing = timing
        self.transport.baud = baud
        self._link.lose(f"reopening the port at {baud} bps")

    def use_state(self, state: StateCache, *, first: bool = True) -> None:
        """Feed ``state`` with every event and read from it what the controllers do (the one
        home of that knowledge: the selection among it). Until then the scheduler keeps a
        cache of its own; call this before ``start``.

        ``first``: before every other subscriber, whenever they subscribe. No answer may
        depend on it (the tests feed the cache last to show that none does).
        """
        self._unfeed()
        self.state_cache = self._core.state = state
        self._unfeed = self._feed(state, first=first)

    def _feed(self, state: StateCache, *, first: bool = True) -> Callable[[], None]:
        # Urgent: the next frame depends on it (selection, motion: ``_must_wait``).
        def feed(e: BusEvent) -> None:  # the depth (a count) only where it is published
            state.handle(e, queue_depth=len(self._queue) if type(e) is TransactionDone else None)

        return self.events.subscribe(feed, first=first, urgent=True)

    def _must_wait(self, request: Request) -> bool:
        """A per-motor request whose F would be refused now: a motor of its controller moves
        (§10 F, 動作中 ×) and another motor, or an unknown one, is selected. It waits (its
        deadline bounds that); the status polls tell when the motion has ended."""
        if request.motor is None:
            return False
        if not self.state_cache.controller(self.name, request.body).moving:
            return False
        if self._core.selected(request.body) == request.motor:
            return False
        return any(needs_selection(c) for c in request.commands)

    def _down_error(self, *, in_flight: bool = False) -> LoopDown:
        retry = None
        if self._retry_at is not None and self.state is not LinkState.CLOSED:
            retry = max(0.0, self._retry_at - self.clock())
        return LoopDown(self.name, self.cause, retry_after=retry, in_flight=in_flight)

    def _fail_queued(self) -> None:
        self._queue.fail_all(self._down_error)
        self._core.stop_waiting.clear()

    def _forget_all(self) -> None:
        for body in BODY_NUMBERS:
            self._core.set_selection(body, None)

    # ------------------------------------------------------------------ the run loop

    async def _run(self) -> None:
        try:
            while self.state is not LinkState.CLOSED:
                if await self._connect():
                    self._first_attempt.set()
                    try:
                        if await self._answered():
                            self._go_up()
                            await self._serve()
                    except LinkLost as exc:
                        await self._go_down(exc.cause)
                    except Exception as exc:  # a defect: fail the callers, reopen, go on
                        log.exception("loop %s: the scheduler failed", self.name)
                        await self._go_down(f"internal error: {exc!r}")
                self._first_attempt.set()
                # Backoff after a failed open and after a loss alike; it is reset by a
                # transaction that heard the line, so a dead line is not reopened in a spin.
                await asyncio.sleep(self._delay)
                self._delay = self._backoff.next_delay()
        finally:
            self._first_attempt.set()

    async def _connect(self) -> bool:
        try:
            await self.transport.open()
        except Exception as exc:
            # TransportClosed and OSError as documented, and whatever else a serial library
            # raises (ValueError for a rate it refuses...): a failed open, never the end of
            # this task, or callers (stops have no deadline) would wait forever.
            if not isinstance(exc, TransportClosed | OSError):
                log.error("loop %s: unexpected error opening %s", self.name, self.transport.url)
            if self.state is not LinkState.DOWN:
                await self._go_down(f"cannot open {self.transport.url}: {exc}")
            else:
                self.cause = f"cannot open {self.transport.url}: {exc}"
                self._retry_at = self.clock() + self._delay
            return False
        self._link.start()
        self._forget_all()
        self._core.framing.forget()
        self._core.detect_failed.clear()
        self._core.deaf_until.clear()
        self._core.silent.clear()
        return True

    async def _answered(self) -> bool:
        """After a reopen: wait until a controller that answered before answers again.

        An open port is not a line: a cut cable opens fine and carries nothing. The loop stays
        down (requests fail at once) until one controller answers a probe; the probes go round
        every ``probe_period`` device seconds, so the loop is up within about that much of the
        line coming back, with one ``LinkUp`` per outage. The first connection has nobody to
        ask: the poller finds the controllers. ``LinkLost`` if the port closes meanwhile.
        """
        if self.state is not LinkState.DOWN or not self._core.answering:
            return True
        pause = self.timing.real(self.config.probe_period)
        while self.state is LinkState.DOWN:
            for body in sorted(self._core.answering):
                if await self._core.probe(body):
                    return True
            self._retry_at = self.clock() + pause
            await asyncio.sleep(pause)
        return False

    def _go_up(self) -> None:
        self._core.silent.clear()
        self.state = LinkState.UP
        self.cause = ""
        self._retry_at = None
        self.events.publish(LinkUp(loop=self.name, time=self.clock()))

    async def _go_down(self, cause: str) -> None:
        if self.state is LinkState.DOWN:  # lost again while probing: one LinkDown per outage
            self.cause = cause
            await self._link.stop()
            with contextlib.suppress(Exception):
                await self.transport.close()
            return
        self.state = LinkState.DOWN
        self.cause = cause
        self.counters.link_downs += 1
        self._retry_at = self.clock() + self._delay
        log.warning("loop %s down: %s", self.name, cause)
        self._fail_queued()
        await self._link.stop()
        with contextlib.suppress(Exception):
            await self.transport.close()
        self.events.publish(
            LinkDown(loop=self.name, time=self.clock(), cause=cause, retry_after=self._delay)
        )

    async def _serve(self) -> None:
        """Run transactions until the link is lost."""
        while True:
            if self._link.lost_cause is not None:
                raise LinkLost(self._link.lost_cause)
            probe = self._core.needs_probe()
            if probe is not None and self._queue.head_priority() is not Priority.STOP:
                # Silence: is it one controller or the line? Ask another one now, so that a
                # cut line is down within a few time-outs, not after the poller's backoff.
                await self._core.probe(probe)
                self._core.check_health(probe)
                continue
            request = self._queue.pop(blocked=self._must_wait)
            if request is None:
                self._core.stop_waiting.clear()
                self._wake.clear()
                await self._wake.wait()
                continue
            await self._execute(request)
            if self._link.heard_any and self._backoff.attempts > 1:
                self._backoff.reset()
                self._delay = self._backoff.next_delay()

    async def _serve_stops(self) -> None:
        """Run the queued stops now (from inside a transaction that holds the line)."""
        stops = self._core.stops_sent
        while (request := self._queue.pop(only=Priority.STOP)) is not None:
            stops[request.body] = stops.get(request.body, 0) + 1
            await self._execute(request)
        self._core.stop_waiting.clear()

    async def _execute(self, request: Request) -> None:
        if self._queue.head_priority() is not Priority.STOP:
            self._core.stop_waiting.clear()
        started = self.clock()
        runner = TransactionRunner(
            self._core, request.body, request.commands, request.motor, request.program
        )
        outermost = self._idle.is_set()  # a stop runs inside the transaction it overtook
        self._idle.clear()
        try:
            results, exchanges = await runner.run()
        except LinkLost as exc:
            self.cause = exc.cause
            self._fail(request, self._down_error(in_flight=True))
            raise
        except asyncio.CancelledError:  # closed during the transaction: nobody waits forever
            self._fail(request, self._down_error(in_flight=True))
            raise
        except Exception as exc:  # a defect: tell the callers, keep the loop alive
            log.exception("loop %s: transaction failed", self.name)
            self._fail(request, exc)
            return
        finally:
            if outermost:
                self._idle.set()
        result = TransactionResult(
            self.name, request.body, tuple(results), started, self.clock(), exchanges
        )
        self.counters.transactions += 1
        # The subscribers hear of it once the next frame is out (the waiters after them).
        self.events.defer()
        self.events.publish(
            TransactionDone(
                loop=self.name,
                time=result.ended,
                body=request.body,
                commands=tuple(request.commands),
                motor=request.motor,
                outcome=result.outcome,
                priority=request.priority,
                duration=result.ended - started,
                exchanges=exchanges,
                counters=self.snapshot(),
            )
        )
        for waiter in request.waiters:
            if not waiter.future.done():
                waiter.future.set_result(result)

    @staticmethod
    def _fail(request: Request, error: Exception) -> None:
        for waiter in (w for w in request.waiters if not w.future.done()):
            waiter.future.set_exception(error)

    # ------------------------------------------------------------------ messages

    def _unsolicited(self, event: Unsolicited) -> None:
        if event.kind is UnsolicitedKind.PROGRAM_OUTPUT and framing_artefact(
            event, self._core.framing, self._link, self.counters
        ):
            return
        body = event.body
        if body is None and event.kind is UnsolicitedKind.PROGRAM_OUTPUT:
            # '>text' and '@' name no controller: the one whose program may run sent it.
            body = self._programs.sole()
        self.counters.unsolicited += 1
        if event.kind is UnsolicitedKind.EEPROM_DONE and body is not None:
            self._core.note_eeprom_done(body)
        self.events.publish(
            UnsolicitedMessage(
                loop=self.name,
                time=self.clock(),
                body=body,
                kind=event.kind,
                data=event.data,
                raw=event.raw,
            )
        )

    def _stray(self, event: ReplyEvent, body: str | None) -> None:
        stray_hint(event, body, self._core.framing)
