"""The stop of a jog whose loop went down while it ran, once the loop is up again.

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

If the loop goes down again before the stop was taken, the stop waits for the next link-up; a
stop the controller refused (``>@``) or that was lost on an up loop for the whole read-back
leaves the operation ``unknown``, saying the axis may still be moving.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from typing import Protocol

from gateway.bus.scheduler import LinkState
from gateway.service.operations.durable import Verdict, read_back_after_restart
from gateway.service.operations.restart_stop import (
    AT_LINK_UP,
    HOLD_TO_RUN,
    RestartStop,
    link_up,
)
from gateway.service.operations.types import Operation, OperationError, OperationState
from gateway.service.runtime.runtime import Runtime

__all__ = ["LOST_LINE", "LineStops"]

log = logging.getLogger("gateway.service")

#: The error kinds of an ``unknown`` end that mean the line was lost under the motion.
LOST_LINE = frozenset({"loop_down"})


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
        gateway: Runtime,
        book: ResolvingBook,
        on_stop: Callable[[RestartStop], object],
    ) -> None:
        self.gateway = gateway
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
        task = asyncio.ensure_future(self._stop(op))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return True

    def pending(self, loop: str, body: str) -> Operation | None:
        """The jog of controller ``loop.body`` still to be stopped or read back, if any."""
        return self._pending.get((loop, body))

    async def _stop(self, op: Operation) -> None:
        key = (op.axis.loop, op.axis.body)
        try:
            verdict = await self._stop_when_up(op)
            state, error, position = verdict
            self._book.resolve(op, state, error, position)
            log.info("operation %s, its line lost mid-jog: %s", op.id, state.value)
        finally:
            if self._pending.get(key) is op:
                del self._pending[key]

    async def _stop_when_up(self, op: Operation) -> Verdict:
        """Stop and read back ``op`` once its loop is up; again after each new outage that
        came before the stop was taken."""
        scheduler = self.gateway.scheduler(op.axis.loop)
        stops: list[RestartStop] = []

        def told(stop: RestartStop) -> None:
            stops.append(stop)
            self._on_stop(stop)

        while True:
            await link_up(self.gateway, op.axis.loop, None)
            verdict = await read_back_after_restart(self.gateway, op, told, AT_LINK_UP)
            # Taken, or refused ('>@'): the controller answered; lost on a loop still up: the
            # read-back gave up on it. Only a new outage is worth the next link-up.
            answered = bool(stops) and (stops[-1].sent or bool(stops[-1].frames))
            if answered or scheduler.state is LinkState.UP:
                return verdict
