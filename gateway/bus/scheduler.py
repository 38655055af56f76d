"""The scheduler of one serial loop: the only writer to its port (DESIGN invariant 1).

``LoopScheduler.submit`` queues a transaction (commands to one controller that no other request
interleaves) and returns its ``TransactionResult``; ``stop`` sends a stop at stop priority;
``upload_program`` uploads a user program as one transaction. What happens on the line is
published on ``events``; ``counters`` and ``trace`` describe the loop.

The scheduler is made of parts, each with its own state, none reading another's privates:

* ``Link``: the port, one exchange at a time (``link``, ``receiver``);
* ``RequestQueue``: the requests waiting, by priority (``queue``);
* ``StopLane``: the stops that go between two frames of a transaction (``stop_lane``);
* ``LineExchange``: one frame, and what the line knows: selection, framing (``exchange``);
* ``LineHealth``: who answers, who is silent: one controller or the line (``line_health``);
* ``LoopLifecycle``: the task that connects, serves the queue, goes down and back (``lifecycle``).

Who calls whom (one way): the scheduler -> the queue (``submit``) and the lifecycle (``start``,
``close``, ``wake``); the lifecycle -> ``TransactionRunner`` -> the exchange -> the link; the
exchange -> the stop lane -> the ``execute`` the lifecycle handed it. The link tells the
scheduler of unsolicited messages and of its loss through the callbacks it was built with.
"""

from __future__ import annotations

import asyncio
import dataclasses
import time
from collections.abc import Callable, Sequence

from gateway.bus.config import LoopConfig
from gateway.bus.counters import Counters, CountersSnapshot
from gateway.bus.events import BusEvent, EventBus, TransactionDone, UnsolicitedMessage
from gateway.bus.exchange import LineExchange
from gateway.bus.lifecycle import LinkState, LoopLifecycle
from gateway.bus.line_health import LineHealth
from gateway.bus.link import Link
from gateway.bus.messages import framing_artefact, stray_hint
from gateway.bus.programs_seen import ProgramsSeen
from gateway.bus.queue import RequestQueue
from gateway.bus.requests import LoopDown, Priority, TransactionError, TransactionResult
from gateway.bus.state import StateCache
from gateway.bus.stop_lane import StopLane
from gateway.bus.timing import Timing
from gateway.bus.trace import FrameDirection, LineTrace
from gateway.protocol import commands as cmd
from gateway.protocol.command_text import REGISTRY
from gateway.protocol.framing import BODY_NUMBERS, Framing
from gateway.protocol.models import Command
from gateway.protocol.program import Program
from gateway.protocol.reply_parser import ReplyEvent, Unsolicited, UnsolicitedKind
from gateway.transport.base import Transport

__all__ = ["LinkState", "LoopScheduler"]

#: The stops' texts, for the errors that refuse something else at stop priority.
_STOPS = ", ".join(sorted(entry.key for entry in REGISTRY.entries if entry.form.is_stop))


class LoopScheduler:
    """Queue, priorities, transactions and link health of one loop.

    ``LoopScheduler(transport, LoopConfig(...))``; ``await start()`` opens the port (one
    attempt; reconnecting goes on in the background); ``await close()`` ends it.
    """

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
        timing = Timing(
            baud=config.baud or transport.baud,
            scale=config.time_scale,
            turnaround=config.turnaround,
            host_latency=config.host_latency,
            quiet_chars=config.quiet_chars,
        )
        self._programs = ProgramsSeen()
        self.events.subscribe(self._programs.handle, urgent=True)  # the parser's `printing`
        self._link = Link(
            transport,
            timing,
            self.counters,
            self.trace,
            on_unsolicited=self._unsolicited,
            on_stray=self._stray,
            on_lost=self._line_lost,
            clock=clock,
            programs=self._programs,
        )
        self._queue = RequestQueue(self.name, clock, self._queued, aging=config.poll_aging_real)
        self._stops = StopLane(self._queue)
        self._health = LineHealth(config, self._link, clock)
        self._exchange = LineExchange(
            self.name,
            config,
            timing,
            self._link,
            self.counters,
            self.events,
            clock,
            stops=self._stops,
            health=self._health,
        )
        self._lifecycle = LoopLifecycle(
            config,
            transport,
            link=self._link,
            exchange=self._exchange,
            health=self._health,
            queue=self._queue,
            stops=self._stops,
            events=self.events,
            counters=self.counters,
            snapshot=self.snapshot,
            clock=clock,
        )
        self._unfeed = self._feed(self._exchange.state)

    # ------------------------------------------------------------------ the loop's state

    @property
    def state(self) -> LinkState:
        """Where the loop's line is."""
        return self._lifecycle.state

    @property
    def cause(self) -> str:
        """Why the line is not up ("" when it is)."""
        return self._lifecycle.cause

    @property
    def timing(self) -> Timing:
        """The line's timing (its rate among it)."""
        return self._exchange.timing

    @property
    def state_cache(self) -> StateCache:
        """The state cache the scheduler feeds first and reads: its own until ``use_state``."""
        return self._exchange.state

    @property
    def queue_depth(self) -> int:
        """Requests waiting to start."""
        return len(self._queue)

    def snapshot(self) -> CountersSnapshot:
        """The loop's counters now."""
        self.counters.coalesced = self._queue.coalesced
        self.counters.expired = self._queue.expired
        return self.counters.snapshot()

    def down_error(self) -> LoopDown:
        """The error of a request refused because the loop is not up (with its retry hint)."""
        return self._lifecycle.down_error()

    # ------------------------------------------------------------------ public

    async def start(self) -> None:
        """Open the port (one attempt) and start serving; reconnects in the background."""
        await self._lifecycle.start()

    async def close(self, *, drain: float = 0.0) -> None:
        """Stop: queued and later requests fail with ``LoopDown``; the port is closed.

        ``drain``: real seconds to let the transaction in flight finish first (graceful
        shutdown: a move half-sent is worse than one refused).
        """
        await self._lifecycle.close(drain)

    def reopen_at(self, baud: int) -> None:
        """Reopen the port at ``baud`` (the controllers were moved there with ``ES``, §10 ES):
        the timing and the transport take the new rate, then the link is lost on purpose and
        the run loop reconnects as after any loss (one LinkDown, queued requests fail with
        LoopDown; the controllers that answered before are probed at the new rate)."""
        timing = dataclasses.replace(self.timing, baud=baud)
        self._link.timing = self._exchange.timing = timing
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
        self._exchange.state = state
        self._unfeed = self._feed(state, first=first)

    async def submit(
        self,
        body: str,
        commands: Command | Sequence[Command],
        *,
        priority: Priority = Priority.OPERATOR,
        motor: int | None = None,
        deadline: float | None = None,
    ) -> TransactionResult:
        """Run ``commands`` on controller ``body`` as one transaction; its result.

        ``motor``: the motor the per-motor commands without a suffix are for (the scheduler
        sends ``F{motor}`` first when needed); None: whatever is selected. ``deadline``: host
        seconds the request may wait to start (default per priority, ``LoopConfig``).
        Raises ``LoopDown``, ``DeadlineExpired``, ``TransactionError``.
        """
        cmds = (commands,) if isinstance(commands, Command) else tuple(commands)
        return await self._submit(body, cmds, priority, motor, deadline, None)

    async def stop(self, body: str, command: Command | None = None) -> TransactionResult:
        """Send a stop (``S`` by default, ``SS`` or ``GES``) at stop priority."""
        command = cmd.stop() if command is None else command
        if not command.form.is_stop:
            raise TransactionError(f"{command.wire()!r} is not a stop: one of {_STOPS}")
        return await self.submit(body, command, priority=Priority.STOP)

    async def upload_program(
        self,
        body: str,
        program: Program,
        *,
        priority: Priority = Priority.OPERATOR,
        deadline: float | None = None,
    ) -> TransactionResult:
        """Upload a user program: ``I``, then its text ended by CR, as one transaction."""
        return await self._submit(body, (cmd.upload_program(),), priority, None, deadline, program)

    def forget(self, body: str | None = None) -> None:
        """Drop what the scheduler knows of a controller's selection and framing (power cycle)."""
        self._exchange.forget(body)

    def selected_motor(self, body: str) -> int | None:
        """The motor the scheduler believes selected on ``body`` (None: not known)."""
        return self._exchange.selected(body)

    def program_may_run(self, body: str) -> bool:
        """Whether ``body``'s user program may be running (``ProgramsSeen``)."""
        return self._programs.may_run(body)

    def resync_figures(self) -> tuple[int, float]:
        """Resyncs of the line so far (after time-outs included) and the host seconds they
        held it (``Link.resync``)."""
        return self._link.resyncs, self._link.resync_time

    def framing(self, body: str) -> Framing:
        """The framing the scheduler uses for ``body``."""
        return self._exchange.framing.get(body)

    # ------------------------------------------------------------------ submitting

    async def _submit(
        self,
        body: str,
        commands: tuple[Command, ...],
        priority: Priority,
        motor: int | None,
        deadline: float | None,
        program: Program | None,
    ) -> TransactionResult:
        if len(body) != 1 or body not in BODY_NUMBERS:
            raise TransactionError(f"body number {body!r} is not one of 0-E (§9-1)")
        if not commands or not all(isinstance(c, Command) for c in commands):
            raise TransactionError("a transaction is one or more command models (never text)")
        if motor not in (None, 1, 2):
            raise TransactionError(f"motor must be 1 or 2, not {motor!r}")
        if self.state in (LinkState.DOWN, LinkState.CLOSED):
            raise self._lifecycle.down_error()
        if all(c.form.is_stop for c in commands):
            priority = Priority.STOP  # a stop outranks everything queued (DESIGN invariant 8)
        elif priority is Priority.STOP:
            # Stop priority jumps the queue, never expires and survives its caller: it is
            # for stops only, or any caller could starve the line with it.
            raise TransactionError(
                f"priority STOP is for stops only ({_STOPS}); "
                f"this transaction has {', '.join(c.wire() for c in commands)}"
            )
        if deadline is None:
            deadline = self.config.deadline_for(priority)
        if priority is Priority.STOP:  # when it was asked for, beside when it went out
            self.trace.add(self.clock(), FrameDirection.NOTE, body, b"", "stop queued")
        waiter = self._queue.put(
            body, commands, priority=priority, motor=motor, program=program, deadline=deadline
        )
        try:
            return await waiter.future
        except asyncio.CancelledError:
            self._queue.discard(waiter)
            raise

    # ------------------------------------------------------------------ what the parts tell

    def _queued(self) -> None:
        self._stops.queued()  # before any frame of a transaction, when a stop heads the queue
        self._lifecycle.wake()

    def _line_lost(self) -> None:
        self._lifecycle.wake()

    def _feed(self, state: StateCache, *, first: bool = True) -> Callable[[], None]:
        # Urgent: the next frame depends on it (selection, motion: ``_must_wait``).
        def feed(e: BusEvent) -> None:  # the depth (a count) only where it is published
            state.handle(e, queue_depth=len(self._queue) if type(e) is TransactionDone else None)

        return self.events.subscribe(feed, first=first, urgent=True)

    def _unsolicited(self, event: Unsolicited) -> None:
        if event.kind is UnsolicitedKind.PROGRAM_OUTPUT and framing_artefact(
            event, self._exchange.framing, self._link, self.counters
        ):
            return
        body = event.body
        if body is None and event.kind is UnsolicitedKind.PROGRAM_OUTPUT:
            # '>text' and '@' name no controller: the one whose program may run sent it.
            body = self._programs.sole()
        self.counters.unsolicited += 1
        if event.kind is UnsolicitedKind.EEPROM_DONE and body is not None:
            self._exchange.note_eeprom_done(body)
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
        stray_hint(event, body, self._exchange.framing)
