"""The stop of a jog whose line was lost while it ran, once the line is back.

A jog runs only while someone holds it (the dashboard's hold-to-jog, a client that ends it
with a stop). When its loop goes down mid-jog (a cut line, a pulled adapter, the link master's
power), the operation ends ``unknown`` (``loop_down``), and its holder's release cannot reach
the controller: the controller may still be jogging, with nobody holding it, when the line comes
back. So, as at a restart (``restart_stop``), the jog is stopped with ``SS`` as soon as its loop
is up (woken by the loop's ``LinkUp``, however long the outage), audited (event
``linkup_stop``), logged, and then read back once its motor stands still: the ``unknown``
operation is re-resolved with what was read (``Operations.resolve``: its new state reaches
``GET /operations/{id}``, the event feed and the audit). The verdicts are the restart's
(``durable``), with the error kind ``loop_down``.

Only jogs (``HOLD_TO_RUN``): a finite move or an origin search ends by itself, and its
``unknown`` end is read back as any other (``motion_watch``). While the stop and its read-back
are under way, a new motion on that controller is refused (409): it would be stopped by this
``SS``, and its motion would be judged in place of the jog's.

The same when only the jog's controller stopped answering (``offline``: its own wiring on the
current loop, a failing receiver): silent is not switched off, and a controller that hears
nothing jogs on. Its stop goes out once it answers again (the poller keeps asking it), audited
as ``answer_stop``, with the error kind ``offline``. A controller that was switched off has
stopped by itself: the stop then changes nothing, and the read-back says where it stands.

If the loop goes down (or the controller silent) again before the stop was taken, the stop
waits for the next link-up (or answer); a stop the controller refused (``>@``) or that was
lost on an up loop for the whole read-back leaves the operation ``unknown``, saying the axis
may still be moving.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from typing import Protocol

from gateway.bus.scheduler import LinkState
from gateway.bus.state_types import Change
from gateway.service.operations.durable import Verdict, read_back_after_restart
from gateway.service.operations.restart_stop import (
    AT_ANSWER,
    AT_LINK_UP,
    HOLD_TO_RUN,
    Occasion,
    RestartStop,
    link_up,
)
from gateway.service.operations.types import Operation, OperationError, OperationState
from gateway.service.runtime.runtime import Runtime

__all__ = ["LOST_LINE", "LineStops"]

log = logging.getLogger("gateway.service")

#: The error kinds of an ``unknown`` end that mean the line was lost under the motion, and
#: what its stop waits for: the loop up again, or the controller answering again.
LOST_LINE: dict[str, Occasion] = {"loop_down": AT_LINK_UP, "offline": AT_ANSWER}


class ResolvingBook(Protocol):
    """What the line stops change of an operation (``Operations`` is one)."""

    def resolve(
        self,
        op: Operation,
        state: OperationState,
        error: OperationError | None,
        position: int | None,
    ) -> None:
        """The ``unknown`` ``op`` read back: its new state to every watcher."""


class LineStops:
    """The jogs whose line was lost under them, each stopped once its loop is up again."""

    def __init__(
        self,
        runtime: Runtime,
        book: ResolvingBook,
        on_stop: Callable[[RestartStop], object],
    ) -> None:
        self.runtime = runtime
        self._book = book
        self._on_stop = on_stop
        #: per controller, the jog waiting for its stop (and its read-back)
        self._pending: dict[tuple[str, str], Operation] = {}
        self._tasks: set[asyncio.Task[None]] = set()

    def close(self) -> None:
        """Abandon the stops under way (the gateway is closing)."""
        for task in self._tasks:
            task.cancel()

    def follow(self, op: Operation) -> bool:
        """``op`` has just ended ``unknown``: if it is a jog whose line was lost, stop it once
        its loop is up again and re-resolve it; True when it is followed here."""
        error = op.error
        if op.kind not in HOLD_TO_RUN or error is None or error.kind not in LOST_LINE:
            return False
        self._pending[op.axis.loop, op.axis.body] = op
        task = asyncio.ensure_future(self._stop(op, LOST_LINE[error.kind]))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return True

    def pending(self, loop: str, body: str) -> Operation | None:
        """The jog of controller ``loop.body`` still to be stopped or read back, if any."""
        return self._pending.get((loop, body))

    async def _stop(self, op: Operation, occasion: Occasion) -> None:
        key = (op.axis.loop, op.axis.body)
        try:
            verdict = await self._stop_when_up(op, occasion)
            state, error, position = verdict
            self._book.resolve(op, state, error, position)
            log.info("operation %s, its line lost mid-jog: %s", op.id, state.value)
        finally:
            if self._pending.get(key) is op:
                del self._pending[key]

    async def _stop_when_up(self, op: Operation, occasion: Occasion) -> Verdict:
        """Stop and read back ``op`` once its loop is up (and, for ``AT_ANSWER``, its
        controller answering); again after each new outage that came before the stop was
        taken."""
        scheduler = self.runtime.scheduler(op.axis.loop)
        stops: list[RestartStop] = []

        def told(stop: RestartStop) -> None:
            stops.append(stop)
            self._on_stop(stop)

        while True:
            await link_up(self.runtime, op.axis.loop, None)
            if occasion is AT_ANSWER:
                await self._answering(op)
            verdict = await read_back_after_restart(self.runtime, op, told, occasion)
            # Taken, or refused ('>@'): the controller answered; lost on a loop still up (and a
            # controller still answering): the read-back gave up on it. Only a new outage is
            # worth the next link-up or answer.
            answered = bool(stops) and (stops[-1].sent or bool(stops[-1].frames))
            silent = occasion is AT_ANSWER and not self._online(op)
            if answered or (scheduler.state is LinkState.UP and not silent):
                return verdict

    def _online(self, op: Operation) -> bool:
        return self.runtime.state.controller(op.axis.loop, op.axis.body).online is True

    async def _answering(self, op: Operation) -> None:
        """Until the poller has found ``op``'s controller answering again."""
        back = asyncio.Event()

        def seen(change: Change) -> None:
            ours = (change.loop, change.body, change.motor) == (op.axis.loop, op.axis.body, None)
            if ours and change.values.get("online") is True:
                back.set()

        unsubscribe = self.runtime.state.changes.subscribe(seen)
        try:
            if not self._online(op):
                await back.wait()
        finally:
            unsubscribe()
