"""Commands that move a motor: §10 0, 0A, 0H, 0R, 0Z, 0Q, 1, 3, 4, 5, 7, 8, 7*, 8*, B, B+(-),
and the ones that change or end a motion: S, SS, H, L.

The controller has already refused a motion command while either motor moves (§2, §9-1 注意)
and in a mode the command does not allow. Here: the motor suffix selects the motor (§10 F);
while EMS is ON a motion command is not executed (§11-4 "/?" example: "非常停止信号が ON して
いる間は、動作コマンドは実行されず") and the EMS flag is latched; with the step-out error set,
every motion command but homing ends in a limit error (§10 9 ⑦, §10 Q).

Mode 1 (§7-4): targets are encoder counts, a position with |pp × PB / PA| >= 8,388,608 makes
3, 4, 5, B, B+(-) end in a limit error without moving, and a move to a target is followed by
the QJ adjustment where QJ asks for it. Mode 2: every motion is followed by the INP wait
(§10 CI, DS ③). Plain motions run under the step-out detection QS asks for (``stepout``).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

from gateway.sim.actions import stop_moving
from gateway.sim.axis import Direction, FollowUp, HomingMethod, HomingSetup
from gateway.sim.dispatch import Refused, handles
from gateway.sim.encoder import ADJUST_UNIT, adjust_plan, within_rule
from gateway.sim.flags import Error
from gateway.sim.memory import POSITION_TABLE_SIZE
from gateway.sim.servo import inp_plan
from gateway.sim.stepout import guard_for

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

#: The first entry a sequential B uses when no B ran since power-on (§10 B 注意点).
FIRST_SEQUENTIAL_ENTRY = 1


def _motor_for_motion(ctl: ControllerView, cmd: Any, *, homing: bool = False) -> int | None:
    """The motor to move, or None when EMS or a step-out error prevents the motion."""
    motor = ctl.motor_of(cmd)
    if ctl.ems_on:
        ctl.flags.raise_(Error.EMERGENCY)
        return None
    if ctl.flags.step_out and not homing:
        ctl.flags.raise_(Error.LIMIT)
        return None
    return motor


def _outside_rule(ctl: ControllerView, position: int) -> bool:
    """Mode 1: a position breaking |pp × PB / PA| < 8,388,608 is a limit error (§7-4 ②)."""
    if ctl.settings.shared.mode != 1:
        return False
    m = ctl.settings.motors[ctl.selected]
    if within_rule(position, m.pa, m.pb):
        return False
    ctl.flags.raise_(Error.LIMIT)
    return True


def _extras(ctl: ControllerView, motor: int, target: int | None = None) -> dict[str, Any]:
    """The step-out detection of a plain motion and what follows it (mode 1 / 2)."""
    shared = ctl.settings.shared
    speeds = ctl.settings.speed(motor)
    after: FollowUp | None = None
    if shared.mode == 2:
        after = FollowUp(inp_plan, speeds)
    adjust = shared.adjust.motor1 if motor == 1 else shared.adjust.motor2
    if shared.mode == 1 and adjust and target is not None:
        axis = ctl.axes[motor]
        wait, limit = shared.adjust_time * ADJUST_UNIT, shared.adjust_limit

        def plan() -> Any:
            return adjust_plan(axis.counts.encoder, lambda: axis.rest, target, wait, limit)

        # §10 QJ form VIII: QJO speed data (0: Low speed), × 300 / OX like OL.
        slow = dataclasses.replace(speeds, ol=shared.adjust_speed or speeds.ol)
        after = FollowUp(plan, slow)
    return {"guard": guard_for(ctl.settings, motor), "after": after}


def _move_to(ctl: ControllerView, motor: int, target: int, now: float) -> None:
    """Absolute move: the distance is target - current, both in the format in force (§7-4)."""
    _move_by(ctl, motor, target - ctl.position(motor, now), now)


def _move_by(ctl: ControllerView, motor: int, distance: int, now: float) -> None:
    """A move of ``distance`` positions (mode 1: encoder counts) from where the motor is."""
    shared = ctl.settings.shared
    settings = ctl.settings.speed(motor)
    axis = ctl.axes[motor]
    target = axis.counter(now) + distance
    # N points serve one move and need trapezoid drive (§10 N 注意点).
    points = tuple(shared.points) if shared.points_on and settings.oc == 0 else ()
    shared.points_on = False
    pulses = axis.counts.pulses_to(axis.mechanical(now), target)
    axis.move(now, pulses, settings, points, **_extras(ctl, motor, target))


@handles("0", "0{mt}", "0A", "0A{mt}", "0H", "0H{mt}", "0R", "0R{mt}", "0Z", "0Q")
def home(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 0, 0A, 0H, 0R, 0Z, 0Q: origin searches."""
    motor = _motor_for_motion(ctl, cmd, homing=True)
    if motor is None:
        return
    if cmd.key == "0Q" and not ctl.axes[motor].sensors(now).step_out_sensor:
        # §10 0Q: the step-out sensor must read ON when 0Q starts ("EA" inverts it otherwise);
        # the manual does not say what happens if not: refused as a command error.
        raise Refused("0Q needs the step-out sensor ON (§10 0Q)")
    m = ctl.settings.motors[motor]
    shared = ctl.settings.shared
    setup = HomingSetup(
        search_pulses=m.search_pulses,
        back_factor=m.back_factor,
        z_count=shared.z_count,
        algorithm=int(shared.new_homing),
        step_out_pulses=m.step_out_pulses,
        mode=shared.mode,
    )
    ctl.axes[motor].home(now, HomingMethod(cmd.mnemonic), setup, ctl.settings.speed(motor))


@handles("1", "1{mt}")
def go_origin(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 1: absolute move to position 0."""
    motor = _motor_for_motion(ctl, cmd)
    if motor is not None:
        _move_to(ctl, motor, 0, now)


@handles("3", "3{mt}")
def go_position_data(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 3: absolute move to the position data of command 2."""
    motor = _motor_for_motion(ctl, cmd)
    target = ctl.shown(ctl.settings.shared.position_data)
    if motor is not None and not _outside_rule(ctl, target):
        _move_to(ctl, motor, target, now)


@handles("4", "4{mt}", "5", "5{mt}")
def step_position_data(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 4 (CW) and 5 (CCW): incremental move by the position data of command 2.

    The pulse count is the position data as shown in the format in force, taken as a count:
    its absolute value, like B+(-) (docs/manual-notes.md "Incremental moves").
    """
    motor = _motor_for_motion(ctl, cmd)
    if motor is None or _outside_rule(ctl, ctl.shown(ctl.settings.shared.position_data)):
        return
    pulses = abs(ctl.shown(ctl.settings.shared.position_data))
    direction = Direction.CW if cmd.mnemonic == "4" else Direction.CCW
    _move_by(ctl, motor, int(direction) * pulses, now)


def _entry_number(ctl: ControllerView, cmd: Any) -> int:
    """The A entry a B form uses, and the sequence it continues (§10 B, B+(-))."""
    if "pn" in cmd.params():
        number = int(cmd.pn)
    elif ctl.rt.next_entry is None:
        number = FIRST_SEQUENTIAL_ENTRY
    else:
        number = ctl.rt.next_entry
    ctl.rt.next_entry = (number + 1) % POSITION_TABLE_SIZE
    return number


@handles("B{pn}", "B{pn}{mt}", "B", "B{mt}")
def go_entry(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 B: absolute move to an entry of the A table; the sequence moves on."""
    motor = _motor_for_motion(ctl, cmd)
    if motor is None:
        return
    number = _entry_number(ctl, cmd)
    if not _outside_rule(ctl, ctl.shown(ctl.table[number])):
        _move_to(ctl, motor, ctl.shown(ctl.table[number]), now)


@handles("B{pn}{dir}", "B{pn}{mt}{dir}", "B{dir}", "B{mt}{dir}")
def step_entry(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 B+(-): incremental move by the absolute value of an entry (§10 B+(-) 注意点)."""
    motor = _motor_for_motion(ctl, cmd)
    if motor is None:
        return
    number = _entry_number(ctl, cmd)
    if _outside_rule(ctl, ctl.shown(ctl.table[number])):
        return
    pulses = abs(ctl.shown(ctl.table[number]))
    direction = Direction.CW if cmd.dir == "+" else Direction.CCW
    _move_by(ctl, motor, int(direction) * pulses, now)


@handles("7", "7{mt}", "8", "8{mt}")
def jog(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 7 (CW) and 8 (CCW): turn at Low speed until S or SS."""
    motor = _motor_for_motion(ctl, cmd)
    if motor is not None:
        direction = Direction.CW if cmd.mnemonic == "7" else Direction.CCW
        ctl.axes[motor].jog(now, direction, ctl.settings.speed(motor), **_extras(ctl, motor))


@handles("7*", "8*")
def single_pulse(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 7*, 8*: one pulse CW or CCW."""
    motor = _motor_for_motion(ctl, cmd)
    if motor is not None:
        direction = Direction.CW if cmd.key == "7*" else Direction.CCW
        ctl.axes[motor].step(now, direction, ctl.settings.speed(motor), **_extras(ctl, motor))


def _moving(ctl: ControllerView, now: float) -> int | None:
    return ctl.moving_motor(now)


@handles("S")
def stop(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 S: stop at once. The motor that moves is stopped, whichever is selected."""
    stop_moving(ctl, now)


@handles("SS")
def slow_stop(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 SS: decelerate to Low speed, then stop."""
    motor = _moving(ctl, now)
    if motor is not None:
        ctl.axes[motor].slow_stop(now)


@handles("H", "L")
def jog_level(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 H, L: a running 7/8 jog to High or Low speed; nothing happens otherwise."""
    motor = _moving(ctl, now)
    if motor is None:
        return
    if cmd.key == "H":
        ctl.axes[motor].to_high(now)
    else:
        ctl.axes[motor].to_low(now)
