"""What service/ and the faces read of a loop's scheduler and poller, wherever they run.

A ``LoopScheduler`` in the API process (the test seam) and a ``SchedulerProxy`` of a line
worker both offer it; ``Runtime.schedulers`` holds one or the other, and service/ names this
surface, never either class, so it cannot come to rely on what only one of them has.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

from gateway.bus.config import LoopConfig
from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import BusEvent, EventBus
from gateway.bus.lifecycle import LinkState
from gateway.bus.requests import LoopDown, Priority, TransactionResult
from gateway.bus.trace import LineTrace
from gateway.protocol.models import Command
from gateway.protocol.program import Program

if TYPE_CHECKING:  # a type only: the API side opens no line
    from gateway.transport.usb_latency import AdapterReport

__all__ = ["LinePoller", "LineScheduler"]


class LineRate(Protocol):
    """The line's rate (a scheduler's ``timing``)."""

    @property
    def baud(self) -> int:
        """Bits per second."""


class LineOpened(Protocol):
    """What opening the line learnt (a scheduler's ``transport``)."""

    @property
    def adapter(self) -> AdapterReport | None:
        """A local USB adapter's report; None: a network line, or not opened yet."""


class LineScheduler(Protocol):
    """One loop's scheduler as service/ calls it."""

    @property
    def name(self) -> str:
        """The loop's name."""

    @property
    def state(self) -> LinkState:
        """The link's state."""

    @property
    def cause(self) -> str:
        """Why the link is not up ("" when it is)."""

    @property
    def events(self) -> EventBus[BusEvent]:
        """The loop's bus events."""

    @property
    def queue_depth(self) -> int:
        """Requests waiting to start."""

    @property
    def config(self) -> LoopConfig:
        """The scheduler's configuration (``time_scale`` among it)."""

    @property
    def timing(self) -> LineRate:
        """The line's rate."""

    @property
    def transport(self) -> LineOpened:
        """What opening the line learnt."""

    @property
    def trace(self) -> LineTrace:
        """The loop's trace."""

    def clock(self) -> float:
        """The host clock the scheduler's times are on."""

    def snapshot(self) -> CountersSnapshot:
        """The loop's counters."""

    def down_error(self) -> LoopDown:
        """The error of a request refused because the loop is not up."""

    def reopen_at(self, baud: int) -> None:
        """Reopen the line at ``baud``."""

    async def submit(
        self,
        body: str,
        commands: Command | Sequence[Command],
        *,
        priority: Priority = Priority.OPERATOR,
        motor: int | None = None,
        deadline: float | None = None,
    ) -> TransactionResult:
        """Run ``commands`` on ``body`` as one transaction."""

    async def stop(self, body: str, command: Command | None = None) -> TransactionResult:
        """Send a stop at stop priority."""

    async def upload_program(
        self,
        body: str,
        program: Program,
        *,
        priority: Priority = Priority.OPERATOR,
        deadline: float | None = None,
    ) -> TransactionResult:
        """Upload a user program."""


class LinePoller(Protocol):
    """One loop's poller as service/ switches it."""

    def start(self) -> None:
        """Start polling."""

    async def stop(self) -> None:
        """Stop polling; returns when no poll is in flight."""
