"""Speed settings and speed-change points: §10 OH, OL, OS, OC, OX (with I/D forms) and N.

A value that breaks the S-curve inequalities of §7-1 (OH, OL, OC) or leaves its range (the
I/D forms) is a command error and the old value stays (§10 OC, OH, OL, OS). A change while the
selected motor moves retunes the motion (§10 OH/OL with OC = 0; §10 OX) from that instant.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from gateway.protocol.reply_values import SpeedPoint
from gateway.protocol.speeds import (
    OS_MAX,
    OX_MAX,
    OX_MIN,
    SPEED_DATA_MAX,
    speed_constraint_violation,
)
from gateway.sim.dispatch import Refused, handles
from gateway.sim.memory import MotorSettings

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

#: (attribute, lowest, highest) of the per-motor speed data (§10 OH, OL, OS, OC).
_RANGES = {
    "OH": ("oh", 1, SPEED_DATA_MAX),
    "OL": ("ol", 1, SPEED_DATA_MAX),
    "OS": ("os", 1, OS_MAX),
    "OC": ("oc", 0, 100),
}


def _set_motor_value(ctl: ControllerView, mnemonic: str, value: int, now: float) -> None:
    name, low, high = _RANGES[mnemonic]
    if not low <= value <= high:
        raise Refused(f"{mnemonic} {value} outside {low}-{high}")
    motor = ctl.settings.motors[ctl.selected]
    speeds = {"oh": motor.oh, "ol": motor.ol, "oc": motor.oc, name: value}
    if speed_constraint_violation(speeds["oh"], speeds["ol"], speeds["oc"]):
        raise Refused("S-curve inequality of §7-1")
    setattr(motor, name, value)
    _retune(ctl, now)


def _retune(ctl: ControllerView, now: float) -> None:
    moving = ctl.moving_motor(now)
    if moving is not None:
        ctl.axes[moving].retune(now, ctl.settings.speed(moving))


def _motor(ctl: ControllerView) -> MotorSettings:
    return ctl.settings.motors[ctl.selected]


@handles("OH{hs}", "OL{ls}", "OS{ss}", "OC{dt}")
def set_speed(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 OH, OL, OS, OC form I: set the selected motor's value."""
    value = next(iter(cmd.params().values()))
    _set_motor_value(ctl, cmd.mnemonic, int(value), now)


@handles("OHI{id}", "OLI{id}", "OSI{id}")
def increase_speed(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 OH, OL, OS form III: add to the value (beyond the range: command error)."""
    name = _RANGES[cmd.mnemonic][0]
    _set_motor_value(ctl, cmd.mnemonic, getattr(_motor(ctl), name) + int(cmd.id), now)


@handles("OHD{dd}", "OLD{dd}", "OSD{dd}")
def decrease_speed(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 OH, OL, OS form IV: subtract from the value (below 1: command error)."""
    name = _RANGES[cmd.mnemonic][0]
    _set_motor_value(ctl, cmd.mnemonic, getattr(_motor(ctl), name) - int(cmd.dd), now)


@handles("OH", "OL", "OS", "OC")
def speed(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 OH, OL, OS, OC form II: the selected motor's value."""
    return int(getattr(_motor(ctl), _RANGES[cmd.mnemonic][0]))


@handles("OX{xs}")
def set_multiplier(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 OX: shared by both motors; the internal value is quantised by ``SpeedSettings``."""
    value = int(cmd.xs)
    if not OX_MIN <= value <= OX_MAX:
        raise Refused(f"OX {value} outside {OX_MIN}-{OX_MAX}")
    ctl.settings.shared.ox = value
    _retune(ctl, now)


@handles("OX")
def multiplier(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 OX: the value as set (docs/manual-notes.md: the set value, not the quantised one)."""
    return ctl.settings.shared.ox


@handles("N{pn}{sp},{pj}")
def set_point(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 N form I: one speed-change point."""
    ctl.settings.shared.points[int(cmd.pn) - 1] = SpeedPoint(int(cmd.sp), int(cmd.pj))


@handles("NS")
def arm_points(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 N form II: the next moves use the points."""
    ctl.settings.shared.points_on = True


@handles("NR")
def disarm_points(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 N form IV: cancel NS."""
    ctl.settings.shared.points_on = False


@handles("NC")
def clear_points(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 N form III: every point back to 0."""
    ctl.settings.shared.points = [SpeedPoint() for _ in ctl.settings.shared.points]


@handles("N")
def points_armed(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 N form V: 1 while NS is in force."""
    return int(ctl.settings.shared.points_on)


@handles("N{pn}")
def point(ctl: ControllerView, cmd: Any, now: float) -> SpeedPoint:
    """§10 N form VI: one point."""
    return ctl.settings.shared.points[int(cmd.pn) - 1]
