"""User-program commands from the host: §10 I, IR, G, GA, GS, GC, GE, GES, GSS, GN, GR, GW.

Part I stores the program text (``I``), reads it back (``IR``), keeps buffers, counters and the
autostart flag, and answers the state queries. Running a program (the interpreter) is simulator
part II: until then ``G`` is refused as a command error, so nobody mistakes the simulator for
one that ran their program (README, "What the simulator does not do yet").
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from gateway.protocol.reply_values import PortByte, ProgramState
from gateway.sim.dispatch import Refused, handles

if TYPE_CHECKING:
    from gateway.sim.controller import Controller


@handles("I")
def open_program(ctl: Controller, cmd: Any, now: float) -> None:
    """§10 I: the next bytes up to CR are the program text (the loop reads them raw)."""
    ctl.rt.awaiting_program = True


@handles("IR")
def program_text(ctl: Controller, cmd: Any, now: float) -> str:
    """§10 IR: the RAM program."""
    return ctl.rt.program


@handles("G", "G{lb}")
def run_program(ctl: Controller, cmd: Any, now: float) -> None:
    """§10 G: not simulated before part II; refused so that no one believes it ran."""
    raise Refused("user programs run in simulator part II")


@handles("GAS", "GAR")
def set_autostart(ctl: Controller, cmd: Any, now: float) -> None:
    """§10 GA: the autostart flag, written to EEPROM at once (no ``$B#*``)."""
    on = cmd.key == "GAS"
    ctl.rt.autostart = on
    ctl.eeprom.write("ga", on)


@handles("GA")
def autostart(ctl: Controller, cmd: Any, now: float) -> int:
    """§10 GA: 1 = autostart on."""
    return int(ctl.rt.autostart)


@handles("GS", "GC", "GE", "GES")
def program_control(ctl: Controller, cmd: Any, now: float) -> None:
    """§10 GS, GC, GE, GES: pause, resume, end; with no program running nothing changes."""
    state = ctl.rt.program_state
    if cmd.key == "GS" and state is ProgramState.RUNNING:
        ctl.rt.program_state = ProgramState.PAUSED
    elif cmd.key == "GC" and state is ProgramState.PAUSED:
        ctl.rt.program_state = ProgramState.RUNNING
    elif cmd.key in ("GE", "GES") and ctl.rt.program_running:
        ctl.rt.program_state = ProgramState.ENDED


@handles("GSS")
def program_state(ctl: Controller, cmd: Any, now: float) -> ProgramState:
    """§10 GSS: the state; E (ended by an error) reads once, then 0."""
    state = ctl.rt.program_state
    if state is ProgramState.ERROR:
        ctl.rt.program_state = ProgramState.ENDED
    return state


@handles("GN")
def program_step(ctl: Controller, cmd: Any, now: float) -> int:
    """§10 GN: the position of the next statement (0 with no program run)."""
    return ctl.rt.step


@handles("GW{bf}{du}{dl}")
def set_buffer(ctl: Controller, cmd: Any, now: float) -> None:
    """§10 GW form I: one data buffer byte."""
    ctl.rt.buffers[str(cmd.bf)] = int(cmd.du) << 4 | int(cmd.dl)


@handles("GW{ct}{dt}")
def set_counter(ctl: Controller, cmd: Any, now: float) -> None:
    """§10 GW form II: one counter."""
    ctl.rt.counters[int(cmd.ct)] = int(cmd.dt)


@handles("GR{bf}")
def buffer(ctl: Controller, cmd: Any, now: float) -> PortByte:
    """§10 GR form I: one data buffer byte (0 until written)."""
    return PortByte(ctl.rt.buffers.get(str(cmd.bf), 0))


@handles("GR{ct}")
def counter(ctl: Controller, cmd: Any, now: float) -> int:
    """§10 GR form II: one counter (0 until written)."""
    return ctl.rt.counters.get(int(cmd.ct), 0)
