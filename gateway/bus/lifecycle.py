"""The loop's task: connect, wait for an answer, serve the queue, go down, reconnect.

``LoopLifecycle`` is one part of a ``LoopScheduler``, with state of its own (the link's
``state`` and ``cause``, the backoff, the task). Its task runs the queue: the highest priority
first, FIFO within a priority, one transaction at a time (``execute``); a stop before the next
frame, inside a transaction too (DESIGN invariant 8): the ``StopLane`` it is handed runs the
stops through ``execute`` when the ``LineExchange`` asks it to. When the transport raises
``TransportClosed``, or ``timeouts_to_down`` time-outs in a row bring no byte, the loop goes
DOWN: queued requests fail at once with ``LoopDown`` (with a retry-after hint) and the port is
reopened with backoff (doubling, with jitter). Once reopened, the exchange forgets what the
controllers were set to (``LineExchange.reopened``); once one answers, ``LinkUp`` is
published: the state layer re-reads the controllers from the devices.

Who calls whom: ``LoopScheduler`` -> ``LoopLifecycle`` (start, close, wake, down_error) ->
``TransactionRunner`` -> ``LineExchange`` -> ``Link``; the exchange -> ``StopLane`` -> the
``execute`` it was handed. Nothing below calls the lifecycle by name.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable
from enum import StrEnum

from gateway.bus.config import LoopConfig
from gateway.bus.counters import Counters, CountersSnapshot
from gateway.bus.events import BusEvent, EventBus, LinkDown, LinkUp, TransactionDone
from gateway.bus.exchange import LineExchange
from gateway.bus.line_health import LineHealth
from gateway.bus.link import Link, LinkLost
from gateway.bus.queue import Request, RequestQueue
from gateway.bus.requests import LoopDown, Priority, TransactionResult
from gateway.bus.selection import needs_selection
from gateway.bus.stop_lane import StopLane
from gateway.bus.transaction import TransactionRunner
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
    """The task that serves one loop's queue over its link, and the link's state."""

    def __init__(
        self,
        config: LoopConfig,
        transport: Transport,
        *,
        link: Link,
        exchange: LineExchange,
        health: LineHealth,
        queue: RequestQueue,
        stops: StopLane,
        events: EventBus[BusEvent],
        counters: Counters,
        snapshot: Callable[[], CountersSnapshot],
        clock: Callable[[], float],
    ) -> None:
        self.config = config
        self.name = config.name
        self._transport = transport
        self._link = link
        self._exchange = exchange
        self._health = health
        self._queue = queue
        self._events = events
        self._counters = counters
        self._snapshot = snapshot
        self._clock = clock
        stops.run_by(self.execute)  # the lane runs its stops the way this task runs a request
        self._stops = stops
        self.state = LinkState.CONNECTING
        self.cause = "not connected yet"
        first = max(1e-6, min(config.reconnect_initial_real, config.reconnect_max_real))
        self._backoff = Backoff(first, max(first, config.reconnect_max_real))  # with jitter
        self._delay = self._backoff.next_delay()  # the next wait before reopening
        self._retry_at: float | None = None
        self._task: asyncio.Task[None] | None = None
        self._first_attempt = asyncio.Event()
        self._wake = asyncio.Event()
        self._idle = asyncio.Event()  # set while no transaction is in flight (shutdown waits)
        self._idle.set()

    # ------------------------------------------------------------------ what the scheduler calls

    async def start(self) -> None:
        """Open the port (one attempt) and start serving; reconnects in the background."""
        if self._task is None:
            self._task = asyncio.get_running_loop().create_task(self._run(), name=self.name)
        await self._first_attempt.wait()

    async def close(self, drain: float) -> None:
        """Fail the queued and later requests, let the transaction in flight end within
        ``drain`` real seconds, end the task and close the port."""
        self.state = LinkState.CLOSED
        self.cause = "the scheduler was closed"
        self._fail_queued()
        if drain > 0:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._idle.wait(), drain)
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        await self._link.stop()
        with contextlib.suppress(Exception):
            await self._transport.close()

    def wake(self) -> None:
        """A request was queued, or the link was lost: look at the queue again."""
        self._wake.set()

    def down_error(self, *, in_flight: bool = False) -> LoopDown:
        """The error of a request refused because the loop is not up (with its retry hint)."""
        retry = None
        if self._retry_at is not None and self.state is not LinkState.CLOSED:
            retry = max(0.0, self._retry_at - self._clock())
        return LoopDown(self.name, self.cause, retry_after=retry, in_flight=in_flight)

    def _must_wait(self, request: Request) -> bool:
        """A per-motor request whose F would be refused now: a motor of its controller moves
        (§10 F, 動作中 ×) and another motor, or an unknown one, is selected. It waits (its
        deadline bounds that); the status polls tell when the motion has ended."""
        if request.motor is None:
            return False
        if not self._exchange.state.controller(self.name, request.body).moving:
            return False
        if self._exchange.selected(request.body) == request.motor:
            return False
        return any(needs_selection(c) for c in request.commands)

    def _fail_queued(self) -> None:
        self._queue.fail_all(self.down_error)
        self._stops.clear()

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
            await self._transport.open()
        except Exception as exc:
            # TransportClosed and OSError as documented, and whatever else a serial library
            # raises (ValueError for a rate it refuses...): a failed open, never the end of
            # this task, or callers (stops have no deadline) would wait forever.
            if not isinstance(exc, TransportClosed | OSError):
                log.error("loop %s: unexpected error opening %s", self.name, self._transport.url)
            if self.state is not LinkState.DOWN:
                await self._go_down(f"cannot open {self._transport.url}: {exc}")
            else:
                self.cause = f"cannot open {self._transport.url}: {exc}"
                self._retry_at = self._clock() + self._delay
            return False
        self._link.start()
        self._exchange.reopened()  # the one place that decides a reopen's doubt
        return True

    async def _answered(self) -> bool:
        """After a reopen: wait until a controller that answered before answers again.

        An open port is not a line: a cut cable opens fine and carries nothing. The loop stays
        down (requests fail at once) until one controller answers a probe; the probes go round
        every ``probe_period`` device seconds, so the loop is up within about that much of the
        line coming back, with one ``LinkUp`` per outage. The first connection has nobody to
        ask: the poller finds the controllers. ``LinkLost`` if the port closes meanwhile.
        """
        if self.state is not LinkState.DOWN or not self._health.answering():
            return True
        pause = self._exchange.timing.real(self.config.probe_period)
        while self.state is LinkState.DOWN:
            for body in self._health.answering():
                if await self._exchange.probe(body):
                    return True
            self._retry_at = self._clock() + pause
            await asyncio.sleep(pause)
        return False

    def _go_up(self) -> None:
        self._health.heard_again()
        self.state = LinkState.UP
        self.cause = ""
        self._retry_at = None
        self._events.publish(LinkUp(loop=self.name, time=self._clock()))

    async def _go_down(self, cause: str) -> None:
        if self.state is LinkState.DOWN:  # lost again while probing: one LinkDown per outage
            self.cause = cause
            await self._link.stop()
            with contextlib.suppress(Exception):
                await self._transport.close()
            return
        self.state = LinkState.DOWN
        self.cause = cause
        self._counters.link_downs += 1
        self._retry_at = self._clock() + self._delay
        log.warning("loop %s down: %s", self.name, cause)
        self._fail_queued()
        await self._link.stop()
        with contextlib.suppress(Exception):
            await self._transport.close()
        self._events.publish(
            LinkDown(loop=self.name, time=self._clock(), cause=cause, retry_after=self._delay)
        )

    async def _serve(self) -> None:
        """Run transactions until the link is lost."""
        while True:
            if self._link.lost_cause is not None:
                raise LinkLost(self._link.lost_cause)
            probe = self._health.needs_probe()
            if probe is not None and self._queue.head_priority() is not Priority.STOP:
                # Silence: is it one controller or the line? Ask another one now, so that a
                # cut line is down within a few time-outs, not after the poller's backoff.
                await self._exchange.probe(probe)
                self._health.check(probe)
                continue
            request = self._queue.pop(blocked=self._must_wait)
            if request is None:
                self._stops.clear()
                self._wake.clear()
                await self._wake.wait()
                continue
            await self.execute(request)
            if self._link.heard_any and self._backoff.attempts > 1:
                self._backoff.reset()
                self._delay = self._backoff.next_delay()

    async def execute(self, request: Request) -> None:
        """Run ``request`` as one transaction, publish it done and answer its callers (the
        serving loop's, and the stop lane's between two frames of another)."""
        self._stops.settle()
        started = self._clock()
        runner = TransactionRunner(
            self._exchange, request.body, request.commands, request.motor, request.program
        )
        outermost = self._idle.is_set()  # a stop runs inside the transaction it overtook
        self._idle.clear()
        try:
            results, exchanges = await runner.run()
        except LinkLost as exc:
            self.cause = exc.cause
            self._fail(request, self.down_error(in_flight=True))
            raise
        except asyncio.CancelledError:  # closed during the transaction: nobody waits forever
            self._fail(request, self.down_error(in_flight=True))
            raise
        except Exception as exc:  # a defect: tell the callers, keep the loop alive
            log.exception("loop %s: transaction failed", self.name)
            self._fail(request, exc)
            return
        finally:
            if outermost:
                self._idle.set()
        result = TransactionResult(
            self.name, request.body, tuple(results), started, self._clock(), exchanges
        )
        self._counters.transactions += 1
        # The subscribers hear of it once the next frame is out (the waiters after them).
        self._events.defer()
        self._events.publish(
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
                counters=self._snapshot(),
            )
        )
        for waiter in request.waiters:
            if not waiter.future.done():
                waiter.future.set_result(result)

    @staticmethod
    def _fail(request: Request, error: Exception) -> None:
        for waiter in (w for w in request.waiters if not w.future.done()):
            waiter.future.set_exception(error)
