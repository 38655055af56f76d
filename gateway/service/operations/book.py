"""Operations: one per motion request, followed from the send to the end of the motion.

An operation goes ``queued`` (created) -> ``sent`` (the controller answered '>') -> ``moving``
(a status read saw the motor turn) -> ``done`` | ``failed`` | ``unknown``. Every change is
published as a ``ServiceEvent`` of kind ``operation`` on topic ``axis:<id>``.

How the end of a motion is seen: ``motion_watch``.

Each operation is written to the state store (``gateway.store``) before its first frame goes
out, together with the ``Idempotency-Key`` of the request that started it
(``store.request_key``); each change after that is queued to the store. ``restore()`` reads
them back at start: the newest ``retention`` stay readable, and one that had not ended when
the process stopped is judged by reading its axis back (``durable``); a new motion on its
controller is refused (409) until then.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import time
from collections import OrderedDict
from collections.abc import Callable, Sequence

from gateway.bus.counting import follow_counter
from gateway.bus.requests import LoopDown, Outcome, ReplyKind, TransactionResult
from gateway.errors import ConflictError, DeviceError, NotFoundError, StateUnavailable
from gateway.protocol.models import Command
from gateway.service.events import EventKind, ServiceEvent
from gateway.service.operations.asked import Asked
from gateway.service.operations.durable import from_record, read_back_after_restart, to_record
from gateway.service.operations.line_stop import LineStops
from gateway.service.operations.motion_watch import MotionWatch
from gateway.service.operations.restart_stop import RestartStop, tell
from gateway.service.operations.types import (
    FINAL,
    Operation,
    OperationError,
    OperationState,
    OperationView,
)
from gateway.service.runtime.runtime import Runtime
from gateway.service.store.records import (
    OPERATION_COUNTER,
    insert_operation,
    load_operations,
    purge,
    request_key,
    save_operation,
)
from gateway.service.topology import AxisRef

__all__ = ["MEMORY", "Operation", "OperationError", "OperationState", "OperationView", "Operations"]

log = logging.getLogger("gateway.service")

#: operations kept in memory (the newest; older ones are read from the store: ``history``)
MEMORY = 1_000


class Operations:
    """Every operation of the gateway (the last ``retention``), and the tracking of the
    active one per controller (its two motors never move together, §2)."""

    def __init__(self, runtime: Runtime, *, retention: int = MEMORY) -> None:
        self.runtime = runtime
        self.retention = retention
        self.forgotten = 0  #: > 0: the store holds operations memory does not (``history``)
        self._ops: OrderedDict[str, Operation] = OrderedDict()
        self._active: dict[tuple[str, str], Operation] = {}
        self._ids = itertools.count(runtime.store.counters.get(OPERATION_COUNTER, 0) + 1)
        self._resolved: list[Callable[[Operation], object]] = []
        self._restart_stops: list[Callable[[RestartStop], object]] = []
        self._watch = MotionWatch(runtime, self)
        self._line_stops = LineStops(runtime, self, lambda stop: tell(self._restart_stops, stop))
        #: per controller, the operation left unended by the last process, being read back
        self._restored: dict[tuple[str, str], Operation] = {}
        self._tasks: set[asyncio.Task[None]] = set()

    def close(self) -> None:
        """Stop listening (the gateway is closing)."""
        self._watch.close()
        self._line_stops.close()
        for task in self._tasks:
            task.cancel()

    async def restore(self) -> None:
        """Read the stored operations back (before the loops start): the newest ``retention``
        and every one not ended, whose axis is then read back (once its loop is up)."""
        store = self.runtime.store
        await store.run(lambda c: purge(c, time.time()))
        records = await store.run(lambda c: load_operations(c, self.retention))
        self.forgotten += len(records) >= self.retention
        for record in records:
            op = from_record(record, self.runtime.topology)
            if op is None or op.id in self._ops:
                continue
            self._store(op)
            if not op.final:
                self._restored[op.axis.loop, op.axis.body] = op
                task = asyncio.ensure_future(self._judge_restored(op))
                self._tasks.add(task)
                task.add_done_callback(self._tasks.discard)
        self._ids = itertools.count(store.counters.get(OPERATION_COUNTER, 0) + 1)

    async def _judge_restored(self, op: Operation) -> None:
        state, error, position = await read_back_after_restart(
            self.runtime, op, lambda stop: tell(self._restart_stops, stop)
        )
        self._restored.pop((op.axis.loop, op.axis.body), None)
        op.position = position if position is not None else op.position
        # Not ``end``: the read-back that an ``unknown`` end starts has just been done here.
        op.error = error
        op.ended = time.time()
        self.advance(op, state)
        op.finished.set()
        log.info("operation %s left by the last process: %s", op.id, state.value)
        for callback in list(self._resolved):
            try:
                callback(op)
            except Exception:  # one bad listener must not stop the others
                log.exception("operation %s: resolution listener failed", op.id)

    # ------------------------------------------------------------------ reading

    def get(self, ident: str) -> Operation:
        """The operation ``ident``; ``NotFoundError`` when unknown (or no longer retained)."""
        op = self._ops.get(ident)
        if op is None:
            raise NotFoundError("operation", ident)
        return op

    def list(
        self, *, axis: str | None = None, state: OperationState | None = None, limit: int = 100
    ) -> list[Operation]:
        """The newest operations first (of ``axis``, in ``state``), at most ``limit``."""
        out: list[Operation] = []
        for op in reversed(self._ops.values()):
            if (axis is None or op.axis.id == axis) and (state is None or op.state is state):
                out.append(op)
                if len(out) >= limit:
                    break
        return out

    def unresolved(self) -> tuple[Operation, ...]:
        """The ``unknown`` operations still waiting for their controller to answer again."""
        return tuple(self._watch.waiting())

    def active(self, loop: str, body: str) -> Operation | None:
        """The operation not yet ended on controller ``loop.body``, if any."""
        return self._active.get((loop, body))

    async def wait(self, ident: str, timeout: float) -> Operation:
        """The operation once it has ended, or as it is after ``timeout`` host seconds."""
        op = self.get(ident)
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(op.finished.wait(), timeout)
        return op

    # ------------------------------------------------------------------ running

    async def run(
        self,
        axis: AxisRef,
        asked: Asked,
        commands: Sequence[Command],
        *,
        motor: int | None,
        target: int | None = None,
        step: int | None = None,
        prefix: str = "$",
        holder: str | None = None,
    ) -> Operation:
        """Create an operation of ``asked``, send ``commands`` as one transaction and follow
        the motion.

        Returns once the controller has answered: the operation is then ``sent`` (or already
        further). A transaction that did not take effect marks it ``failed`` / ``unknown`` and
        raises: ``LoopDown`` / ``DeadlineExpired`` / ``TransactionError`` as the scheduler
        did, ``ConflictError`` for a command refused with '>@' (ER1), ``DeviceError`` for no
        usable answer. The transaction runs to its end even if the caller goes away.
        """
        key = (axis.loop, axis.body)
        if key in self._active:
            raise ConflictError(
                f"controller {axis.controller_id} has operation {self._active[key].id} "
                "in progress (§2: its two motors never move together)",
                field="axis",
            )
        restored = self._restored.get(key) or self._line_stops.pending(*key)
        if restored is not None:
            raise ConflictError(
                f"controller {axis.controller_id}: operation {restored.id}, a jog nobody holds "
                "any more (the gateway stopped, or its loop went down, under it), is being "
                "stopped and read back; a motion now would make it unknowable",
                field="axis",
            )
        unsure = self._watch.reading_back(*key)
        if unsure is not None:
            raise ConflictError(
                f"controller {axis.controller_id}: the outcome of operation {unsure.id} is "
                "being read back; a motion now would make it unknowable",
                field="axis",
            )
        number = next(self._ids)
        op = Operation(
            id=f"op-{number}-{int(time.time() * 1000) % 100_000_000:08d}",
            axis=axis,
            asked=asked,
            motor=motor or axis.motor,
            target=target,
            holder=holder,
            commands=tuple(commands),
            prefix=prefix,
            step=step,
        )
        self._active[key] = op
        record, started_by = to_record(op), request_key.get()
        write = asyncio.ensure_future(
            self.runtime.store.run(lambda c: insert_operation(c, number, record, started_by))
        )
        try:
            # On disk before the first frame: after a crash, the key finds this operation.
            await asyncio.shield(write)
        except asyncio.CancelledError:
            # The caller went away first: nothing is sent. The end is queued after the write.
            self._store(op)
            detail = "the request went away before the operation was recorded; nothing was sent"
            self.end(op, OperationState.FAILED, OperationError.of("refused", "Not sent", detail))
            raise
        except Exception as exc:
            del self._active[key]
            raise StateUnavailable(
                f"operation {op.id} could not be recorded in the state store ({exc}); "
                "nothing was sent"
            ) from exc
        self._store(op)
        self._publish(op)
        scheduler = self.runtime.scheduler(axis.loop)
        task = asyncio.ensure_future(scheduler.submit(axis.body, commands, motor=motor))
        try:
            result = await asyncio.shield(task)
        except asyncio.CancelledError:
            task.add_done_callback(lambda t: self._sent(op, t))
            raise
        except LoopDown as exc:
            state = OperationState.UNKNOWN if exc.in_flight else OperationState.FAILED
            self.end(op, state, OperationError.of("loop_down", "Loop down", str(exc)))
            raise
        except Exception as exc:
            self.end(op, OperationState.FAILED, OperationError.of("refused", "Refused", str(exc)))
            raise
        self._after(op, result)
        return op

    def _sent(self, op: Operation, task: asyncio.Future[TransactionResult]) -> None:
        """The transaction of a caller that went away has ended."""
        if task.cancelled() or task.exception() is not None:
            error = OperationError.of("refused", "Not sent", str(task.exception() or "cancelled"))
            self.end(op, OperationState.UNKNOWN, error)
            return
        try:
            self._after(op, task.result())
        except Exception as exc:  # nobody is waiting for the error any more
            log.info("operation %s: %s", op.id, exc)

    def _after(self, op: Operation, result: TransactionResult) -> None:
        """Record the transaction's result; raise what a caller must learn."""
        op.frames = result.frames
        for command_result in result.results:
            before = command_result.seen.get("position_before")
            if isinstance(before, int) and not isinstance(before, bool):
                # As the state cache keeps positions: the counter followed through its wraps.
                axis = self.runtime.state.axis(op.axis.loop, op.axis.body, op.motor)
                op.position_before = follow_counter(before, axis.position)
        outcome = result.outcome
        if outcome is Outcome.DONE:
            if op.sent is None:
                op.sent = time.time()
            if op.state is OperationState.QUEUED:
                self.advance(op, OperationState.SENT)
            else:
                self._save(op)  # the frames and the pre-read
            return
        first = next(r for r in result.results if r.outcome is not Outcome.DONE)
        detail = f"{first.command.wire()}: {first.kind.value}" + (
            f" ({first.note})" if first.note else ""
        )
        if outcome is Outcome.UNKNOWN:
            self.end(
                op,
                OperationState.UNKNOWN,
                OperationError.of("device", "Outcome unknown", detail, "unknown"),
            )
            raise DeviceError(
                f"operation {op.id}: the controller's answer leaves the outcome in doubt: {detail}",
                outcome="unknown",
                timeout=first.kind is ReplyKind.TIMEOUT,
            )
        self.end(
            op, OperationState.FAILED, OperationError.of("device", "Not done", detail, "not_done")
        )
        if first.kind is ReplyKind.REJECTED:
            raise ConflictError(
                f"operation {op.id}: the controller refused {first.command.wire()} with a "
                "command error ('>@', §10 ER)",
                field="command",
            )
        raise DeviceError(
            f"operation {op.id}: the command was not carried out: {detail}",
            outcome="not_done",
            timeout=first.kind is ReplyKind.TIMEOUT,
        )

    def note_stop(self, loop: str, body: str) -> Operation | None:
        """A stop was sent to controller ``loop.body``: the active operation ends there."""
        op = self._active.get((loop, body))
        if op is not None:
            op.stop_requested = True
        return op

    # ------------------------------------------------------------------ bookkeeping

    def _store(self, op: Operation) -> None:
        self._ops[op.id] = op
        while len(self._ops) > self.retention:
            oldest = next((i for i, o in self._ops.items() if o.state in FINAL), None)
            if oldest is None:  # one still running is never dropped
                break
            del self._ops[oldest]
            self.forgotten += 1

    def running(self) -> tuple[Operation, ...]:
        """Every operation not yet ended (one at most per controller)."""
        return tuple(self._active.values())

    def advance(self, op: Operation, state: OperationState) -> None:
        """``op`` is now in ``state`` (sent, moving), published to every watcher."""
        op.state = state
        op.updated = time.time()
        self._save(op)
        self._publish(op)

    def end(self, op: Operation, state: OperationState, error: OperationError | None) -> None:
        """``op`` ended in ``state``: it leaves its controller, its waiters wake, and an
        ``unknown`` end is read back once the controller answers again."""
        if op.state in FINAL:
            return
        op.error = error
        op.ended = time.time()
        if self._active.get(key := (op.axis.loop, op.axis.body)) is op:
            del self._active[key]
        op.commands = ()  # kept to tell its transaction's end; memory holds 1,000 ended ops
        self.advance(op, state)
        op.finished.set()
        if state is OperationState.UNKNOWN and not self._line_stops.follow(op):
            self._watch.read_back_later(op)

    def resolve(
        self,
        op: Operation,
        state: OperationState,
        error: OperationError | None,
        position: int | None,
    ) -> None:
        """An ``unknown`` operation read back once its controller answered again: its new
        state reaches every watcher (operation status, events, ``on_resolved``)."""
        if op.state is not OperationState.UNKNOWN:
            return
        op.error = error
        op.position = position
        self.advance(op, state)
        for callback in list(self._resolved):
            try:
                callback(op)
            except Exception:  # one bad listener must not stop the others
                log.exception("operation %s: resolution listener failed", op.id)

    def on_resolved(self, callback: Callable[[Operation], object]) -> None:
        """Call ``callback(op)`` whenever an ``unknown`` operation is resolved (the audit)."""
        self._resolved.append(callback)

    def on_restart_stop(self, callback: Callable[[RestartStop], object]) -> None:
        """Call ``callback(stop)`` for each jog left running by the last process (the audit)."""
        self._restart_stops.append(callback)

    def _save(self, op: Operation) -> None:
        """Queue ``op`` as it is now for the state store (the run's own write was awaited)."""
        record = to_record(op)
        self.runtime.store.post(lambda c: save_operation(c, record))

    def _publish(self, op: Operation) -> None:
        data = op.view().model_dump(mode="json")
        self.runtime.events.publish(
            ServiceEvent(EventKind.OPERATION, f"axis:{op.axis.id}", time.time(), data)
        )
