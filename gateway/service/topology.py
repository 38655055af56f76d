"""Which loops, controllers and axes exist, their ids and names, units and soft limits.

Ids are positional and never change: a controller is ``loop.body`` (``main.1``), an axis
``loop.body.motor`` (``main.1.2``). Names come from the configuration and are unique across
the gateway; a name never contains a dot, so an id and a name cannot be confused. Every
controller has both its motors, named or not (§2: two motors a controller).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

from gateway.errors import InvalidInputError, NotFoundError
from gateway.protocol.framing import Series
from gateway.protocol.params import UNSIGNED_MAX
from gateway.service.config import AxisSettings, GatewayConfig, LoopSettings

__all__ = ["AxisRef", "ControllerRef", "LoopRef", "Topology"]

#: The position counter's range as the controller shows it signed (§7-4, §10 EP: 24 bits).
POSITION_MIN = -8_388_608
POSITION_MAX = 8_388_607


@dataclass(frozen=True)
class AxisRef:
    """One motor: where it is, what it is called, its unit and soft limits."""

    loop: str
    body: str
    motor: int
    name: str | None
    unit: str
    units_per_pulse: float
    soft_min: float | None  # user units
    soft_max: float | None

    @property
    def id(self) -> str:
        """``loop.body.motor``."""
        return f"{self.loop}.{self.body}.{self.motor}"

    @property
    def controller_id(self) -> str:
        """``loop.body``."""
        return f"{self.loop}.{self.body}"

    def to_user(self, pulses: int | None) -> float | None:
        """A pulse count in user units (None stays None)."""
        if pulses is None:
            return None
        return round(pulses * self.units_per_pulse, 9)

    def to_pulses(self, value: float, field: str) -> int:
        """User units to whole pulses; refused when not a whole number of pulses (±1e-6)."""
        pulses = value / self.units_per_pulse
        # round() of an infinity raises OverflowError: look at it first
        nearest = round(pulses) if math.isfinite(pulses) else 0
        if not math.isfinite(pulses) or abs(pulses - nearest) > 1e-6:
            raise InvalidInputError(
                f"{value} {self.unit} is not a whole number of pulses on axis {self.id}",
                field=field,
                rule=f"a position is a whole number of pulses of {self.units_per_pulse} "
                f"{self.unit}",
            )
        return int(nearest)

    def check_target(self, pulses: int, field: str) -> None:
        """Refuse a target outside the soft limits or any view of the position counter
        (§7-4); the controller's own format narrows it (``position_format.check_target``)."""
        if not POSITION_MIN <= pulses <= UNSIGNED_MAX:
            raise InvalidInputError(
                f"target {pulses} pulses is outside the position counter",
                field=field,
                rule=f"targets lie in {POSITION_MIN}..{UNSIGNED_MAX} pulses (§7-4)",
            )
        user = pulses * self.units_per_pulse
        low, high = self.soft_min, self.soft_max
        if (low is not None and user < low - 1e-9) or (high is not None and user > high + 1e-9):
            raise InvalidInputError(
                f"target {user:g} {self.unit} is outside the soft limits of axis {self.id}",
                field=field,
                rule=f"soft limits [{_fmt(low)}, {_fmt(high)}] {self.unit} (configuration)",
            )


def _fmt(value: float | None) -> str:
    return "-inf" if value is None else f"{value:g}"


@dataclass(frozen=True)
class ControllerRef:
    """One controller on a loop and its two axes."""

    loop: str
    body: str
    name: str | None
    series: Series
    axes: tuple[AxisRef, AxisRef]

    @property
    def id(self) -> str:
        """``loop.body``."""
        return f"{self.loop}.{self.body}"


@dataclass(frozen=True)
class LoopRef:
    """One loop as configured."""

    name: str
    settings: LoopSettings
    controllers: tuple[ControllerRef, ...]

    @property
    def bodies(self) -> tuple[str, ...]:
        """The body numbers configured on the loop."""
        return tuple(c.body for c in self.controllers)


def _axis(loop: str, body: str, motor: int, cfg: AxisSettings | None) -> AxisRef:
    cfg = cfg or AxisSettings(motor=motor)
    return AxisRef(
        loop, body, motor, cfg.name, cfg.unit, cfg.units_per_pulse, cfg.soft_min, cfg.soft_max
    )


class Topology:
    """Every loop, controller and axis of a configuration, by id and by name."""

    def __init__(self, config: GatewayConfig) -> None:
        self._loops: dict[str, LoopRef] = {}
        self._ctls: dict[str, ControllerRef] = {}
        self._axes: dict[str, AxisRef] = {}
        self._names: dict[str, str] = {}  # name -> id
        for loop in config.loops:
            ctls = []
            for ctl in loop.controllers:
                by_motor = {a.motor: a for a in ctl.axes}
                axes = (
                    _axis(loop.name, ctl.body, 1, by_motor.get(1)),
                    _axis(loop.name, ctl.body, 2, by_motor.get(2)),
                )
                ref = ControllerRef(loop.name, ctl.body, ctl.name, Series(ctl.series), axes)
                ctls.append(ref)
                self._ctls[ref.id] = ref
                if ref.name:
                    self._names[ref.name] = ref.id
                for axis in axes:
                    self._axes[axis.id] = axis
                    if axis.name:
                        self._names[axis.name] = axis.id
            self._loops[loop.name] = LoopRef(loop.name, loop, tuple(ctls))

    # ------------------------------------------------------------------ listing

    def loops(self) -> Iterator[LoopRef]:
        """Every loop, in configuration order."""
        return iter(self._loops.values())

    def controllers(self, loop: str | None = None) -> Iterator[ControllerRef]:
        """Every controller (of ``loop``), in configuration order."""
        return (c for c in self._ctls.values() if loop is None or c.loop == loop)

    def axes(self, loop: str | None = None) -> Iterator[AxisRef]:
        """Every axis (of ``loop``), controller by controller, motor 1 first."""
        return (a for a in self._axes.values() if loop is None or a.loop == loop)

    # ------------------------------------------------------------------ resolving

    def loop(self, ident: str) -> LoopRef:
        """The loop called ``ident``; ``NotFoundError`` otherwise."""
        try:
            return self._loops[ident]
        except KeyError:
            raise NotFoundError("loop", ident, known=tuple(self._loops)) from None

    def controller(self, ident: str) -> ControllerRef:
        """The controller with id (``loop.body``) or name ``ident``."""
        ref = self._ctls.get(self._names.get(ident, ident))
        if ref is None:
            raise NotFoundError("controller", ident, known=self._known(self._ctls))
        return ref

    def axis(self, ident: str) -> AxisRef:
        """The axis with id (``loop.body.motor``) or name ``ident``."""
        ref = self._axes.get(self._names.get(ident, ident))
        if ref is None:
            raise NotFoundError("axis", ident, known=self._known(self._axes))
        return ref

    def _known(self, table: dict[str, ControllerRef] | dict[str, AxisRef]) -> tuple[str, ...]:
        named = [name for name, ident in self._names.items() if ident in table]
        return (*table.keys(), *named)
