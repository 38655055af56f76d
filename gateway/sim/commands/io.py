"""The I/O port, the CLR outputs and the timer: §10 C, CI, CO, D, DA, DS, P, T, GRT, GWT.

Inputs come from the control surface. ``CI`` (mode 2) reads the servo driver's INP and ``DS``
shows the 100 µs CLR pulses of mode 2 besides what ``DS`` forces (``servo``). The ``K`` error
output ORs its bits into the general outputs (the controller, ``error_output``). The timer is
the one internal timer that T, T*, P and GWT share (§10 T 注意点); ``$B#T`` is sent at
time-up of ``T`` only.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from gateway.protocol.framing import TIMER_UP
from gateway.protocol.reply_values import ClrState, InputsWithInp, OutputsWithClr, PortByte
from gateway.sim.dispatch import Refused, handles
from gateway.sim.ram_state import Timer

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

TENTH = 0.1  # the timer's unit (§10 T: TIME x 100 ms)


@handles("C")
def inputs(ctl: ControllerView, cmd: Any, now: float) -> PortByte:
    """§10 C form I: general inputs 7-0."""
    return PortByte(ctl.rt.inputs)


@handles("C{bit}")
def input_bit(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 C form II: one input; 8 and 9 are INP1 and INP2."""
    bit = int(cmd.bit)
    if bit >= 8:
        return int(ctl.rt.inp[bit - 8])
    return ctl.rt.inputs >> bit & 1


@handles("CA")
def inputs_inp(ctl: ControllerView, cmd: Any, now: float) -> InputsWithInp:
    """§10 C form III: INP1/INP2 and the inputs."""
    return InputsWithInp(ctl.rt.inp[0], ctl.rt.inp[1], PortByte(ctl.rt.inputs))


@handles("CI", "CI{mt}")
def inp(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 CI (mode 2): the servo's INP of a motor; ``CI{mt}`` keeps the selection (§10 F)."""
    motor = int(cmd.mt) if cmd.motor is not None else ctl.selected
    return int(ctl.axes[motor].inp(now))


def _outputs(ctl: ControllerView, now: float) -> int:
    pulse = ctl.rt.pulse
    if pulse is not None and ctl.rt.timer.timed_up(now):
        ctl.rt.outputs &= ~(1 << pulse)  # §10 P: the bit goes OFF when the time is up
        ctl.rt.pulse = None
    return ctl.rt.outputs


@handles("CO")
def outputs(ctl: ControllerView, cmd: Any, now: float) -> PortByte:
    """§10 CO form I: general outputs 7-0."""
    return PortByte(_outputs(ctl, now))


@handles("COA")
def outputs_clr(ctl: ControllerView, cmd: Any, now: float) -> OutputsWithClr:
    """§10 CO form II: CLR1/CLR2 and the outputs."""
    clr = ctl.rt.clr
    return OutputsWithClr(clr.clr1, clr.clr2, PortByte(_outputs(ctl, now)))


@handles("CO{bit}")
def output_bit(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 CO form III: one output; 8 and 9 are CLR1 and CLR2 (§4-5)."""
    bit = int(cmd.bit)
    if bit == 8:
        return int(ctl.rt.clr.clr1)
    if bit == 9:
        return int(ctl.rt.clr.clr2)
    return _outputs(ctl, now) >> bit & 1


@handles("D{du}{dl}")
def set_outputs(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 D form I: all eight outputs."""
    _outputs(ctl, now)
    ctl.rt.outputs = int(cmd.du) << 4 | int(cmd.dl)


@handles("D{bit}{value}B")
def set_output_bit(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 D form II: one output."""
    bit, on = int(cmd.bit), bool(int(cmd.value))
    value = _outputs(ctl, now)
    ctl.rt.outputs = value | (1 << bit) if on else value & ~(1 << bit)


@handles("D{clr}{value}B")
def set_clr_bit(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 D form III: CLR1 (8) or CLR2 (9) used as a general output."""
    on = bool(int(cmd.value))
    clr = ctl.rt.clr
    ctl.rt.clr = ClrState(on, clr.clr2) if int(cmd.clr) == 8 else ClrState(clr.clr1, on)


@handles("DA{dc}{du}{dl}")
def set_all_outputs(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 D form IV: CLR2/CLR1 (DC bits 1/0) and the eight outputs."""
    dc = int(cmd.dc)
    ctl.rt.clr = ClrState(bool(dc & 1), bool(dc & 2))
    _outputs(ctl, now)
    ctl.rt.outputs = int(cmd.du) << 4 | int(cmd.dl)


@handles("DS{c2}{c1}")
def force_clr(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 DS form I: CLR2 and CLR1 ON/OFF."""
    ctl.rt.clr = ClrState(bool(int(cmd.c1)), bool(int(cmd.c2)))


@handles("DSR")
def release_clr(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 DS form II: both CLR outputs OFF."""
    ctl.rt.clr = ClrState()


@handles("DS")
def clr_state(ctl: ControllerView, cmd: Any, now: float) -> ClrState:
    """§10 DS form III: the CLR outputs, forced or pulsing (§10 DS ①-⑥)."""
    clr = ctl.rt.clr
    return ClrState(
        clr.clr1 or ctl.axes[1].servo.clr_on(now), clr.clr2 or ctl.axes[2].servo.clr_on(now)
    )


def _start_timer(ctl: ControllerView, tenths: int, now: float, *, report: bool) -> None:
    ctl.rt.timer = Timer(started=now, tenths=tenths, report=report)
    if report:
        timer = ctl.rt.timer
        ctl.later(tenths * TENTH, TIMER_UP, now, still=lambda: ctl.rt.timer is timer)


@handles("P{bt}{time}")
def pulse_output(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 P: output bit ON now, OFF after TIME x 0.1 s (it uses the internal timer)."""
    _outputs(ctl, now)
    bit = int(cmd.bt)
    ctl.rt.outputs |= 1 << bit
    ctl.rt.pulse = bit
    _start_timer(ctl, int(cmd.time), now, report=False)


@handles("T{time}", "T*{time}")
def start_timer(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 T forms I/II: start the timer; only T reports time-up with ``$B#T``."""
    _start_timer(ctl, int(cmd.time), now, report=cmd.key == "T{time}")


@handles("T")
def timer_state(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 T form III: 1 while counting, 0 once timed up."""
    return int(not ctl.rt.timer.timed_up(now))


@handles("GRT")
def timer_left(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 GRT: the remaining time in 0.1 s."""
    return ctl.rt.timer.remaining(now)


@handles("GWT{time}")
def rewrite_timer(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 GWT: the counting timer goes on from a new remaining time; with the timer up (not
    in use) it is a command error (§10 GWT 注意点)."""
    old = ctl.rt.timer
    if old.timed_up(now):
        raise Refused("GWT while the timer is up, i.e. not in use (§10 GWT)")
    _start_timer(ctl, int(cmd.time), now, report=old.report and not old.timed_up(now))
