"""Homing and sensor set-up, encoder and step-out settings, sensor reads, error output.

§10 0B, 0Q (pd, D, W), 0S, 0X, 0Z (n, D), EA, PA, PB, Q, QD, QE, QJ, QJT, QJA, QJO, QS, QSE,
RD, CL, CLM, K, KC. What the encoder and step-out settings do to a motion is the business of
``encoder``, ``stepout`` and ``servo`` (read when a motion starts); ``K``'s outputs are turned
ON by the controller (``error_output``).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

from gateway.protocol.reply_values import (
    ErrorOutput,
    ErrorWatch,
    MotorPair,
    PortByte,
    SensorBits,
    SensorLogic,
)
from gateway.sim.dispatch import Refused, handles
from gateway.sim.flags import Error
from gateway.sim.memory import MotorSettings

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

#: Per-motor homing/encoder values: form key -> (attribute, parameter).
_MOTOR_SETTERS = {
    "0B{n}": ("back_factor", "n"),
    "0Q{pd}": ("step_out_pulses", "pd"),
    "0S{pd}": ("search_pulses", "pd"),
    "PA{dt}": ("pa", "dt"),
    "PB{ra}": ("pb", "ra"),
    "Q{s1}": ("step_out_period", "s1"),
}
_MOTOR_QUERIES = {"0B": "back_factor", "0QD": "step_out_pulses", "0S": "search_pulses",
                  "PA": "pa", "PB": "pb", "QD": "step_out_period"}  # fmt: skip
#: Shared values: form key -> (attribute, parameter).
_SHARED_SETTERS = {
    "0Z{n}": ("z_count", "n"),
    "QE{dt}": ("step_out_window", "dt"),
    "QJT{time}": ("adjust_time", "time"),
    "QJA{pp}": ("adjust_limit", "pp"),
    "QJO{ps}": ("adjust_speed", "ps"),
}
_SHARED_QUERIES = {"0ZD": "z_count", "QE": "step_out_window", "QJT": "adjust_time",
                   "QJA": "adjust_limit", "QJO": "adjust_speed"}  # fmt: skip
_PAIRS = {"QS": "step_out_detect", "QJ": "adjust", "QSE": "encoder_step_out"}


def _motor(ctl: ControllerView) -> MotorSettings:
    return ctl.settings.motors[ctl.selected]


@handles(*_MOTOR_SETTERS)
def set_motor_value(ctl: ControllerView, cmd: Any, now: float) -> None:
    """A per-motor value of the selected motor (§10 F list)."""
    name, param = _MOTOR_SETTERS[cmd.key]
    setattr(_motor(ctl), name, int(getattr(cmd, param)))
    ctl.configure_axes(now)  # PA, PB: the encoder's ratio from here on


@handles(*_MOTOR_QUERIES)
def motor_value(ctl: ControllerView, cmd: Any, now: float) -> int:
    """A per-motor value of the selected motor."""
    return int(getattr(_motor(ctl), _MOTOR_QUERIES[cmd.key]))


@handles("QD{mt}")
def step_out_period_of(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 Q form IV: the period of a given motor; the selection stays (§10 F)."""
    return ctl.settings.motors[int(cmd.mt)].step_out_period


@handles(*_SHARED_SETTERS)
def set_shared_value(ctl: ControllerView, cmd: Any, now: float) -> None:
    """A value shared by both motors."""
    name, param = _SHARED_SETTERS[cmd.key]
    setattr(ctl.settings.shared, name, int(getattr(cmd, param)))


@handles(*_SHARED_QUERIES)
def shared_value(ctl: ControllerView, cmd: Any, now: float) -> int:
    """A value shared by both motors."""
    return int(getattr(ctl.settings.shared, _SHARED_QUERIES[cmd.key]))


@handles("0X1", "0X0")
def set_homing_algorithm(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 0X: the mode-2 homing algorithm."""
    ctl.settings.shared.new_homing = cmd.key == "0X1"


@handles("0X")
def homing_algorithm(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 0X: 1 = new algorithm."""
    return int(ctl.settings.shared.new_homing)


@handles("0QW")
def step_out_width(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 0Q form IV: the ON width counted by the last 0Q centring."""
    return int(ctl.axes[ctl.selected].step_out_width)


@handles("QS{m2}{m1}", "QJ{m2}{m1}", "QSE{m2}{m1}")
def set_pair(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 QS, QJ, QSE: one digit per motor, written for both at once."""
    setattr(ctl.settings.shared, _PAIRS[cmd.mnemonic], MotorPair(int(cmd.m1), int(cmd.m2)))


@handles("QSR", "QJR", "QSER")
def clear_pair(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 QSR, QJR, QSER: the function off for both motors."""
    setattr(ctl.settings.shared, _PAIRS[cmd.mnemonic], MotorPair())


@handles("QS", "QJ", "QSE")
def pair(ctl: ControllerView, cmd: Any, now: float) -> MotorPair:
    """§10 QS, QJ, QSE queries."""
    value: MotorPair = getattr(ctl.settings.shared, _PAIRS[cmd.mnemonic])
    return value


@handles("Q")
def step_out_detected(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 Q form I: 1 when a step-out has been detected (the latch of 9 bit 6)."""
    return int(ctl.flags.step_out)


@handles("RD")
def clear_step_out(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 RD (mode 1): clear the step-out error; moves start again from the encoder count."""
    ctl.flags.step_out = False


# ---------------------------------------------------------------------- sensor logic (EA)


def _set_logic(ctl: ControllerView, motors: tuple[int, ...], byte: int) -> None:
    try:
        logic = SensorLogic.from_byte(byte)
    except ValueError as exc:  # an unused bit (0, 6, 7) set
        raise Refused(str(exc)) from exc
    for n in motors:
        ctl.settings.motors[n].logic = logic
        ctl.axes[n].logic = logic
    ctl.settings.shared.ems_logic = logic.emergency_stop


@handles("EA{du}{dl}")
def set_logic(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 EA form I: the selected motor's logic byte; the EMS bit is common."""
    _set_logic(ctl, (ctl.selected,), int(cmd.du) << 4 | int(cmd.dl))


@handles("EA{bit}{value}B")
def set_logic_bit(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 EA form II: one bit of the selected motor's logic byte."""
    byte = ctl.settings.logic(ctl.selected).byte
    bit = int(cmd.bit)
    byte = byte | (1 << bit) if int(cmd.value) else byte & ~(1 << bit)
    _set_logic(ctl, (ctl.selected,), byte)


@handles("EAH", "EAL")
def set_logic_preset(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 EA forms III/IV: both motors as an RC-231HA (0E) or an RC-231 (00)."""
    _set_logic(ctl, (1, 2), 0x0E if cmd.key == "EAH" else 0x00)


@handles("EA")
def logic(ctl: ControllerView, cmd: Any, now: float) -> SensorLogic:
    """§10 EA form V: the selected motor's logic byte, with the common EMS bit."""
    return ctl.settings.logic(ctl.selected)


# ---------------------------------------------------------------------- sensors (CL)


def _sensors(ctl: ControllerView, motor: int, now: float) -> SensorBits:
    bits = ctl.axes[motor].sensors(now)
    return dataclasses.replace(bits, emergency_stop=ctl.ems_on)


def _reported_motor(ctl: ControllerView, now: float) -> int:
    # §10 CL 注意点: while moving, form I reports the moving motor.
    moving = ctl.moving_motor(now)
    return ctl.selected if moving is None else moving


@handles("CL")
def sensors(ctl: ControllerView, cmd: Any, now: float) -> SensorBits:
    """§10 CL form I: the sensors of the selected (or moving) motor."""
    return _sensors(ctl, _reported_motor(ctl, now), now)


@handles("CL{bit}")
def sensor(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 CL form II: one sensor bit."""
    byte = _sensors(ctl, _reported_motor(ctl, now), now).byte
    return byte >> int(cmd.bit) & 1


@handles("CLM{mt}")
def sensors_of(ctl: ControllerView, cmd: Any, now: float) -> SensorBits:
    """§10 CL form III: the sensors of motor MT; the selection stays (§10 F)."""
    return _sensors(ctl, int(cmd.mt), now)


# ---------------------------------------------------------------------- error output (K)


def _set_error_output(ctl: ControllerView, watch: int, outputs: int) -> None:
    ctl.settings.shared.error_output = ErrorOutput(ErrorWatch(watch), PortByte(outputs))
    ctl.flags.clear_status(Error.LIMIT | Error.EMERGENCY)  # §10 K forms I, II


@handles("K{dt},{du}{dl}")
def set_error_mask(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 K form I: watch errors DT, output mask DU DL."""
    _set_error_output(ctl, int(cmd.dt), int(cmd.du) << 4 | int(cmd.dl))


@handles("K{dt},{bt}")
def set_error_bit(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 K form II: watch errors DT, one output bit."""
    _set_error_output(ctl, int(cmd.dt), 1 << int(cmd.bt))


@handles("K0")
def error_output_off(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 K form III: the function off; bits already ON stay ON."""
    ctl.settings.shared.error_output = ErrorOutput()


@handles("KC")
def error_output_clear(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 K form IV: the function's bits OFF, limit and EMS status bits cleared.

    KC while the function is off is a command error (§10 K 注意点).
    """
    setting = ctl.settings.shared.error_output
    if not setting.enabled:
        raise Refused("KC with the error-output function off (§10 K)")
    ctl.rt.outputs &= ~setting.outputs.value
    ctl.flags.clear_status(Error.LIMIT | Error.EMERGENCY)


@handles("K")
def error_output(ctl: ControllerView, cmd: Any, now: float) -> ErrorOutput:
    """§10 K form V: the setting."""
    return ctl.settings.shared.error_output
