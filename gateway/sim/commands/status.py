"""Flags, motor selection, mode, position format, pulse method, framing queries, baud, version.

§10 "", 9, F, E, EP, ED, EE, EL, ER, SUM, ES, V. The framing setters (EE1, EL0, ...) are
handled by the controller itself, because they change the framing of their own reply.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from gateway.protocol.framing import SWITCH_FIELDS
from gateway.protocol.params import PositionFormat
from gateway.protocol.reply_values import ConditionFlags, StatusFlags, Version
from gateway.sim.dispatch import handles
from gateway.sim.flags import Error
from gateway.sim.memory import Baud

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView


@handles('""')
def status(ctl: ControllerView, cmd: Any, now: float) -> StatusFlags:
    """§10 "": moving is live; bits 1-3 are reported and then cleared."""
    moving = ctl.moving_motor(now) is not None
    errors = ctl.flags.read_status()
    return StatusFlags(
        moving=moving,
        limit_error=Error.LIMIT in errors,
        emergency_stop=Error.EMERGENCY in errors,
        command_error=Error.COMMAND in errors,
    )


def _condition(ctl: ControllerView, errors: Error) -> ConditionFlags:
    return ConditionFlags(
        communication_error=Error.COMMUNICATION in errors,
        limit_error=Error.LIMIT in errors,
        emergency_stop=Error.EMERGENCY in errors,
        command_error=Error.COMMAND in errors,
        mode=ctl.settings.shared.mode,
        step_out=ctl.flags.step_out,
        selected_motor=ctl.selected,
    )


@handles("9")
def condition(ctl: ControllerView, cmd: Any, now: float) -> ConditionFlags:
    """§10 9 form I: bits 0-3 reported and cleared; step-out (bit 6) stays."""
    return _condition(ctl, ctl.flags.read_condition())


@handles("9{bit}")
def condition_bit(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 9 form II: one bit, the mode number for bits 4 and 5; clears nothing."""
    bit = int(cmd.bit)
    if bit in (4, 5):
        return ctl.settings.shared.mode
    flags = _condition(ctl, ctl.flags.condition)
    values = {
        0: flags.communication_error,
        1: flags.limit_error,
        2: flags.emergency_stop,
        3: flags.command_error,
        6: flags.step_out,
        7: flags.selected_motor == 2,
    }
    return int(values[bit])


@handles("F{mt}")
def select(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 F: select the motor that commands without a suffix act on."""
    ctl.selected = int(cmd.mt)


@handles("F")
def selected(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 F: the selected motor."""
    return ctl.selected


@handles("E{mode}")
def set_mode(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 E: the operating mode (both motors); mode 1 counts encoder pulses (§7-4)."""
    ctl.settings.shared.mode = int(cmd.mode)
    ctl.configure_axes(now)


@handles("E")
def mode(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 E: the operating mode."""
    return ctl.settings.shared.mode


@handles("EP1", "EP0")
def set_position_format(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 EP: signed or unsigned management of the same 24-bit counters."""
    signed = cmd.key == "EP1"
    ctl.settings.shared.positions = PositionFormat.SIGNED if signed else PositionFormat.UNSIGNED


@handles("EP")
def position_format(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 EP: 1 signed, 0 unsigned (the setting, whatever the mode)."""
    return int(ctl.settings.shared.positions is PositionFormat.SIGNED)


@handles("ED1", "ED0")
def set_pulse_output(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 ED: 2P (CW/CCW) or 1P (pulse and direction) outputs."""
    ctl.settings.shared.pulse_output = 1 if cmd.key == "ED1" else 0


@handles("ED")
def pulse_output(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 ED: the pulse output method."""
    return ctl.settings.shared.pulse_output


@handles("EE", "EL", "ER", "SUM")
def framing_switch(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 EE, EL, ER, SUM queries: 1 on, 0 off."""
    return int(getattr(ctl.framing, SWITCH_FIELDS[cmd.key]))


@handles("ES{bp}")
def set_baud(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 ES: the new rate is written to EEPROM and applies after this reply."""
    baud = Baud(int(cmd.bp))
    ctl.eeprom.write("es", baud.value)
    # The '>' already computed goes out at the old rate; the loop reads the new one for the
    # next frame (§10 ES: effective right after this command).
    ctl.baud = baud


@handles("ES")
def baud(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 ES: the current rate's digit."""
    return ctl.baud.value


@handles("V")
def version(ctl: ControllerView, cmd: Any, now: float) -> Version:
    """§10 V: the ROM version."""
    return ctl.version
