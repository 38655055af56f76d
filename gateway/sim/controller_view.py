"""The simulated controller as its command handlers and its program interpreter see it.

Handlers (``sim.commands``) and the interpreter (``sim.program``) act on a controller; the
controller (``sim.controller``) calls them. Typing them against this protocol rather than the
``Controller`` class keeps that call one-way: the controller imports its handlers, never the
reverse, and this list says exactly what a handler may read and change.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from gateway.protocol.framing import Framing, Series
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.protocol.reply_values import Version
from gateway.sim.axis import Axis
from gateway.sim.eeprom import Eeprom
from gateway.sim.flags import Flags
from gateway.sim.memory import Baud, Settings
from gateway.sim.ram_state import Runtime

__all__ = ["ControllerView"]


class ControllerView(Protocol):
    """One RC-233: its settings, axes, flags, EEPROM and run state, and what acts on them."""

    body: str
    series: Series
    version: Version
    eeprom: Eeprom
    settings: Settings
    table: list[int]
    axes: dict[int, Axis]
    flags: Flags
    selected: int
    baud: Baud
    rt: Runtime

    @property
    def framing(self) -> Framing:
        """The controller's framing switches (EE, EL, ER, SUM)."""
        ...

    @property
    def position_format(self) -> PositionFormat:
        """How positions are written: mode 1 is always signed (§7-4), else EP."""
        ...

    @property
    def ems_on(self) -> bool:
        """The EMS input as the controller reads it."""
        ...

    def program_rules(self, command: Command, now: float) -> None:
        """``Refused`` when a program statement breaks the mode or while-moving rules."""
        ...

    def emit(self, at: float, data: bytes) -> None:
        """Program output sent at ``at``."""
        ...

    def later(
        self, delay: float, message: str, now: float, *, still: Callable[[], bool] | None = None
    ) -> None:
        """Send ``$B#message`` CR ``delay`` seconds from ``now``."""
        ...

    def busy(self, until: float, now: float) -> None:
        """Stay silent until ``until`` and then send ``$B#*``."""
        ...

    def advance(self, now: float) -> None:
        """Bring both axes to ``now`` and latch what stopped them."""
        ...

    def configure_axes(self, now: float) -> None:
        """Apply the mode, PA and PB to the axes."""
        ...

    def moving_motor(self, now: float) -> int | None:
        """The motor that is moving, if any."""
        ...

    def motor_of(self, command: Command) -> int:
        """The motor a command acts on (a motor suffix selects it)."""
        ...

    def position(self, motor: int, now: float) -> int:
        """The position counter of ``motor`` as the controller reports it."""
        ...

    def shown(self, counter: int) -> int:
        """A stored 24-bit value in the current position format."""
        ...
