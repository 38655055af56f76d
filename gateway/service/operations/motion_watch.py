"""How the end of a motion is seen, for ``Operations``.

The end of a motion is seen in the status reads (``""``) that follow the send: the poller
reads ``""`` every ``moving_period`` while a motor moves (its position back to back, between
the status reads), and the scheduler publishes
every reply, whoever asked. ``""`` clears its error bits on the device (§10 "" 注意点), so the
errors are taken from the reads themselves: a limit error or an emergency stop reported after
the send makes the operation ``failed``, as does a command error before the motor was ever
seen moving (the controller ignored the command, §9-1 注意). The final position is the next
position read (the poller's position stream reads it again once a ``""`` has seen the end),
or a read of our own when none comes.

Watching the events rather than state changes: the cache publishes a field only when it moves,
so a move too short for any read to see it moving would change nothing there. The events come
through the state cache (``StateCache.follow``), once it has learnt from them: whether the
controller moves is the cache's word (``ControllerState.moving``), never a record of its own;
the operation keeps only its own state (``moving`` once a read after its send saw the motion).
"""

from __future__ import annotations

import asyncio
import logging
import time
from dataclasses import dataclass, field
from typing import Any, Protocol

from gateway.bus.counting import follow_counter
from gateway.bus.events import BusEvent, LinkDown, ReplyObserved, TransactionDone
from gateway.bus.requests import Outcome
from gateway.bus.state_types import Change
from gateway.protocol import commands as cmd
from gateway.protocol.reply_values import StatusFlags
from gateway.protocol.spec import Effect
from gateway.service.operations.types import FINAL, Operation, OperationError, OperationState
from gateway.service.runtime.runtime import Runtime

__all__ = ["FINAL_READ_WAIT", "READ_BACK_HOLD", "MotionWatch"]

log = logging.getLogger("gateway.service")

#: Host seconds to wait for the poller's position read after the end before reading it here.
FINAL_READ_WAIT = 0.5
#: Host seconds a new motion on a controller waits (409) for the read-back of an ``unknown``
#: operation there, so that the read-back judges that operation and not the next one.
READ_BACK_HOLD = 2.0

_LIMIT = OperationError(
    kind="limit_error",
    title="Limit error",
    detail='a limit sensor turned on during the motion, or a step-out error stopped it (§10 "" '
    "bit 1)",
)
_EMERGENCY = OperationError(
    kind="emergency_stop",
    title="Emergency stop",
    detail='the EMS input stopped the motion (§10 "" bit 2)',
)
_COMMAND = OperationError(
    kind="command_error",
    title="Command error",
    detail='the controller ignored the command (§10 "" bit 3): a motion command while a motor '
    "moves, a step-out error, or a mode restriction (§9-1 注意, §10 9)",
)


class OperationBook(Protocol):
    """What the watch reads and moves of the operations it follows (``Operations`` is one):
    the book keeps the operations and publishes each change; the watch decides the changes."""

    def active(self, loop: str, body: str) -> Operation | None:
        """The operation not yet ended on controller ``loop.body``, if any."""

    def running(self) -> tuple[Operation, ...]:
        """Every operation not yet ended."""

    def advance(self, op: Operation, state: OperationState) -> None:
        """``op`` is now in ``state`` (sent, moving): not an end."""

    def end(self, op: Operation, state: OperationState, error: OperationError | None) -> None:
        """``op`` ended in ``state`` (done, failed, unknown)."""

    def resolve(
        self,
        op: Operation,
        state: OperationState,
        error: OperationError | None,
        position: int | None,
    ) -> None:
        """The ``unknown`` ``op`` read back once its controller answered again."""


class MotionWatch:
    """Follows the active operation of each controller to its end, from the bus events."""

    def __init__(
        self,
        runtime: Runtime,
        book: OperationBook,
    ) -> None:
        self.runtime = runtime
        self._book = book
        #: per controller, the ``unknown`` operation to read back when it answers again
        self._unknown: dict[tuple[str, str], _ReadBack] = {}
        self._tasks: set[asyncio.Task[Any]] = set()
        self._unsubscribe = [
            runtime.state.follow(self._on_bus),
            runtime.state.changes.subscribe(self._on_change),
        ]

    def close(self) -> None:
        """Stop listening; abandon the final reads under way."""
        for unsubscribe in self._unsubscribe:
            unsubscribe()
        for task in self._tasks:
            task.cancel()

    def _on_bus(self, event: BusEvent) -> None:
        if isinstance(event, LinkDown):
            for running in self._book.running():
                if running.axis.loop == event.loop and running.state not in FINAL:
                    error = OperationError.of("loop_down", "Loop down", event.cause, "unknown")
                    self._book.end(running, OperationState.UNKNOWN, error)
            return
        body = getattr(event, "body", None)
        if isinstance(event, ReplyObserved) and (event.loop, event.body) in self._unknown:
            self._read_back(self._unknown[event.loop, event.body], event)
        op = self._book.active(event.loop, body) if isinstance(body, str) else None
        if op is None:
            return
        if isinstance(event, TransactionDone):
            # The move's own transaction has ended: reads from now on see its motion.
            if not op.armed and event.commands == op.commands and event.outcome is Outcome.DONE:
                op.armed = True
        elif isinstance(event, ReplyObserved) and op.armed:
            if isinstance(event.value, StatusFlags):
                self._status(op, event.value)
            elif op.ending is not None and event.command.form.reads_position:
                motor = event.command.motor or event.motor
                if motor == op.motor and isinstance(event.value, int) and not op.ending.done():
                    op.ending.set_result(self._followed(op, event.value))

    def _status(self, op: Operation, flags: StatusFlags) -> None:
        """A status read after ``op``'s send (the cache has just learnt it)."""
        if flags.limit_error:
            op.errors.add("limit_error")
        if flags.emergency_stop:
            op.errors.add("emergency_stop")
        seen_moving = op.state is OperationState.MOVING
        if flags.command_error and not seen_moving:
            op.errors.add("command_error")
        if self.runtime.state.controller(op.axis.loop, op.axis.body).moving:
            if not seen_moving:
                if op.state is OperationState.QUEUED:
                    # the read came before the send returned: the send is done all the same,
                    # and every client sees each state in order (sent, then moving)
                    if op.sent is None:
                        op.sent = time.time()
                    self._book.advance(op, OperationState.SENT)
                self._book.advance(op, OperationState.MOVING)
        elif op.ending is None:
            op.ending = asyncio.get_running_loop().create_future()
            task = asyncio.ensure_future(self._finish(op, op.ending))
            self._tasks.add(task)
            task.add_done_callback(self._tasks.discard)

    async def _finish(self, op: Operation, ending: asyncio.Future[int]) -> None:
        """The motion has ended: its final position, then its verdict."""
        position: int | None
        try:
            position = await asyncio.wait_for(asyncio.shield(ending), FINAL_READ_WAIT)
        except TimeoutError:
            position = await self._read_position(op)
        if op.state in FINAL:
            return
        op.position = position
        if self._reached(op, position):
            # The axis stands at the end of this motion: it was carried out. An error the
            # device latched meanwhile (another command's, or a status reply bent on the
            # line) stays on the controller for clients to see; it is not this motion's.
            self._book.end(op, OperationState.DONE, None)
            return
        if self._short(op) and not op.rechecked:
            # Short of its end and no error seen: the status read that showed the stop may
            # have been bent on the line. Read again before judging.
            op.rechecked = True
            flags, position = await self._recheck(op)
            if op.state in FINAL:
                return
            if flags is not None and flags.moving:
                op.ending = None  # still turning: the next status read that shows the stop
                return
            op.position = position if position is not None else op.position
            if self._reached(op, op.position):
                self._book.end(op, OperationState.DONE, None)
                return
        if "limit_error" in op.errors:
            self._book.end(op, OperationState.FAILED, _LIMIT)
        elif "emergency_stop" in op.errors:
            self._book.end(op, OperationState.FAILED, _EMERGENCY)
        elif "command_error" in op.errors:
            self._book.end(op, OperationState.FAILED, _COMMAND)
        elif op.stop_requested and op.kind != "jog":
            detail = f"a stop request ended the {op.kind} at {position} pulses"
            if op.target is not None:
                detail += f", before its target {op.target}"
            self._book.end(
                op, OperationState.FAILED, OperationError.of("stopped", "Stopped", detail)
            )
        elif self._short(op) and op.position is not None:
            # Either the motion stopped short for a reason nobody reported, or a reply bent
            # on the line (the pre-read) gave a wrong end: the gateway cannot tell.
            detail = (
                f"the {op.kind} ended at {op.position} pulses, not at the end {op.expected_end} "
                f"its pre-read ({op.position_before}) gives, and the controller reported no error"
            )
            error = OperationError.of("not_reached", "Target not reached", detail, "unknown")
            self._book.end(op, OperationState.UNKNOWN, error)
        else:
            self._book.end(op, OperationState.DONE, None)

    @staticmethod
    def _reached(op: Operation, position: int | None) -> bool:
        """At the end of its motion, and away from where it started."""
        return (
            position is not None and position == op.expected_end and position != op.position_before
        )

    @staticmethod
    def _short(op: Operation) -> bool:
        """A move or step that ended elsewhere than its end, with no error and no stop."""
        return (
            op.kind in ("move", "step")
            and op.expected_end is not None
            and op.position != op.expected_end
            and not op.errors
            and not op.stop_requested
        )

    async def _recheck(self, op: Operation) -> tuple[StatusFlags | None, int | None]:
        """The status and the position of ``op``'s axis, read now."""
        try:
            result = await self.runtime.scheduler(op.axis.loop).submit(
                op.axis.body, [cmd.status(), cmd.position(op.motor)]
            )
        except Exception as exc:
            log.info("operation %s: end not read again: %s", op.id, exc)
            return None, None
        flags, position = (r.value for r in result.results)
        return (
            flags if isinstance(flags, StatusFlags) else None,
            self._followed(op, position)
            if isinstance(position, int) and not isinstance(position, bool)
            else None,
        )

    async def _read_position(self, op: Operation) -> int | None:
        try:
            result = await self.runtime.scheduler(op.axis.loop).submit(
                op.axis.body, cmd.position(op.motor)
            )
        except Exception as exc:
            log.info("operation %s: final position not read: %s", op.id, exc)
            return None
        value = result.value
        if isinstance(value, int) and not isinstance(value, bool):
            return self._followed(op, value)
        return None

    def _followed(self, op: Operation, reported: int) -> int:
        """A position reply of ``op``'s axis as the state cache keeps it: the counter followed
        through its wraps (``gateway.bus.counting``), so ends and pre-reads compare alike."""
        cached = self.runtime.state.axis(op.axis.loop, op.axis.body, op.motor).position
        return follow_counter(reported, cached)

    def _on_change(self, change: Change) -> None:
        """A controller that stops answering ends its operation in doubt."""
        if change.body is None or change.motor is not None:
            return
        if change.values.get("online") is False:
            op = self._book.active(change.loop, change.body)
            if op is not None and op.state not in FINAL:
                error = OperationError.of(
                    "offline", "Controller offline", "the controller stopped answering", "unknown"
                )
                self._book.end(op, OperationState.UNKNOWN, error)

    # ------------------------------------------------------------------ read back

    def waiting(self) -> list[Operation]:
        """The ``unknown`` operations waiting to be read back."""
        return [rb.op for rb in self._unknown.values()]

    def read_back_later(self, op: Operation) -> None:
        """``op`` ended ``unknown``: judge it once its controller answers again (a status read
        that shows no motion, then a position read of its motor, against the pre-read)."""
        if op.position_before is None or op.expected_end is None:
            return  # nothing to compare a read-back with: it stays unknown, with its reason
        rb = _ReadBack(op, since=asyncio.get_running_loop().time())
        self._unknown[op.axis.loop, op.axis.body] = rb
        rb.reading = True  # ask now: the poller's next status read may be a second away
        task = asyncio.ensure_future(self._recheck(op))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    def reading_back(self, loop: str, body: str) -> Operation | None:
        """The ``unknown`` operation of ``loop.body`` being read back right now (for at most
        ``READ_BACK_HOLD`` s): a new motion would make its read-back meaningless."""
        rb = self._unknown.get((loop, body))
        if rb is None or asyncio.get_running_loop().time() - rb.since > READ_BACK_HOLD:
            return None
        return rb.op

    def _read_back(self, rb: _ReadBack, event: ReplyObserved) -> None:
        op, value = rb.op, event.value
        key = (op.axis.loop, op.axis.body)
        if op.state is not OperationState.UNKNOWN:
            del self._unknown[key]
            return
        accepted = value is None and not event.rejected
        if accepted and event.command.form.effect is Effect.MOTION:
            del self._unknown[key]  # another motion started: the read-back would judge it
            return
        if isinstance(value, StatusFlags):
            rb.settled = not value.moving
            if value.limit_error:
                rb.errors.add("limit_error")
            if value.emergency_stop:
                rb.errors.add("emergency_stop")
            if rb.settled and not rb.reading:
                rb.reading = True
                task = asyncio.ensure_future(self._read_position(op))
                self._tasks.add(task)
                task.add_done_callback(self._tasks.discard)
        elif rb.settled and event.command.form.reads_position:
            motor = event.command.motor or event.motor
            if motor == op.motor and isinstance(value, int) and not isinstance(value, bool):
                del self._unknown[key]
                self._judge(op, self._followed(op, value), rb.errors)

    def _judge(self, op: Operation, position: int, errors: set[str]) -> None:
        expected, before = op.expected_end, op.position_before
        seen = f"read back when the controller answered again: {position} pulses"
        if position == expected:
            self._book.resolve(op, OperationState.DONE, None, position)
        elif position == before:
            error = OperationError.of(
                "device", "Not done", f"{seen}, where it started: not carried out", "not_done"
            )
            self._book.resolve(op, OperationState.FAILED, error, position)
        elif errors:
            error = _LIMIT if "limit_error" in errors else _EMERGENCY
            self._book.resolve(op, OperationState.FAILED, error, position)
        elif op.error is not None:
            # Neither the start nor the end: it moved and stopped short; nobody can tell why.
            detail = f"{op.error.detail}; {seen}, neither the start {before} nor the end {expected}"
            error = op.error.model_copy(update={"detail": detail})
            self._book.resolve(op, OperationState.UNKNOWN, error, position)


@dataclass
class _ReadBack:
    """An ``unknown`` operation waiting for its controller to answer again."""

    op: Operation
    since: float = 0.0  # host time the follow-up started
    settled: bool = False  # a status read has shown no motion since
    reading: bool = False  # a position read was asked for
    errors: set[str] = field(default_factory=set)
