"""User-program commands from the host: §10 I, IR, G, GA, GS, GC, GE, GES, GSS, GN, GR, GW.

``I`` takes the program text, ``IR`` reads it back, ``G`` starts the interpreter
(``gateway.sim.program``), ``GS``/``GC``/``GE``/``GES`` pause, resume and end it, ``GSS`` and
``GN`` report its state and step, ``GR``/``GW`` read and write its buffers and counters, and
``GA`` sets the autostart that runs it at power-on (``start_program``, called at boot).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from gateway.protocol.reply_values import PortByte, ProgramState
from gateway.sim.actions import stop_moving
from gateway.sim.dispatch import Refused, handles
from gateway.sim.program import Machine

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView


@handles("I")
def open_program(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 I: the next bytes up to CR are the program text (the loop reads them raw)."""
    ctl.rt.awaiting_program = True


@handles("IR")
def program_text(ctl: ControllerView, cmd: Any, now: float) -> str:
    """§10 IR: the RAM program."""
    return ctl.rt.program


def start_program(ctl: ControllerView, label: str | None, now: float) -> None:
    """Run the RAM program from the start, or after ``/G{label}`` (§10 G, §10 GA).

    ``Refused`` (a command error) when RAM holds no program or the label is not in it
    (§10 G 注意点). Nothing else is checked here: statements are checked when they run.
    """
    text = ctl.rt.program
    if not text:
        raise Refused("no user program in RAM (§10 G 注意点)")
    machine = Machine(text)
    step = 1
    if label is not None:
        found = machine.labels.get(label)
        if found is None:
            raise Refused(f"no /G{label} in the program (§10 G 注意点)")
        step = found + 1  # §10 G (II): from the statement after the label
    ctl.rt.machine = machine
    machine.start(ctl, step, now)


@handles("G", "G{lb}")
def run_program(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 G: run the RAM program (refused while one runs: §11-3 5., by the rules)."""
    start_program(ctl, str(cmd.lb) if cmd.key == "G{lb}" else None, now)


@handles("GAS", "GAR")
def set_autostart(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 GA: the autostart flag, written to EEPROM at once (no ``$B#*``)."""
    on = cmd.key == "GAS"
    ctl.rt.autostart = on
    ctl.eeprom.write("ga", on)


@handles("GA")
def autostart(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 GA: 1 = autostart on."""
    return int(ctl.rt.autostart)


@handles("GS", "GC", "GE", "GES")
def program_control(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 GS, GC, GE, GES: pause, resume, end; with no program running nothing changes.

    GS pauses at a statement boundary: a wait under way (a motion, the timer) runs to its end
    first, then nothing more runs until GC (§10 GS "動作の区切りまで実行した後"). GE ends the
    program and leaves a motion running (§10 GE); GES also stops the motor at once (§10 GES).
    """
    state = ctl.rt.program_state
    machine = ctl.rt.machine
    if cmd.key == "GS" and state is ProgramState.RUNNING:
        ctl.rt.program_state = ProgramState.PAUSED
    elif cmd.key == "GC" and state is ProgramState.PAUSED:
        ctl.rt.program_state = ProgramState.RUNNING
        if machine is not None:
            machine.resume(now)
    elif cmd.key in ("GE", "GES") and ctl.rt.program_running:
        if machine is not None:
            machine.end(ctl)
        ctl.rt.program_state = ProgramState.ENDED
        if cmd.key == "GES":
            stop_moving(ctl, now)


@handles("GSS")
def program_state(ctl: ControllerView, cmd: Any, now: float) -> ProgramState:
    """§10 GSS: the state; E (ended by an error) reads once, then 0."""
    state = ctl.rt.program_state
    if state is ProgramState.ERROR:
        ctl.rt.program_state = ProgramState.ENDED
    return state


@handles("GN")
def program_step(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 GN: the '/' count of the statement that runs next (0 before any G).

    After ``/END`` it names the ``/END``; after a command error, the statement that failed.
    """
    return ctl.rt.step


@handles("GW{bf}{du}{dl}")
def set_buffer(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 GW form I: one data buffer byte."""
    ctl.rt.buffers[str(cmd.bf)] = int(cmd.du) << 4 | int(cmd.dl)


@handles("GW{ct}{dt}")
def set_counter(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 GW form II: one counter."""
    ctl.rt.counters[int(cmd.ct)] = int(cmd.dt)


@handles("GR{bf}")
def buffer(ctl: ControllerView, cmd: Any, now: float) -> PortByte:
    """§10 GR form I: one data buffer byte (0 until written)."""
    return PortByte(ctl.rt.buffers.get(str(cmd.bf), 0))


@handles("GR{ct}")
def counter(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 GR form II: one counter (0 until written)."""
    return ctl.rt.counters.get(int(cmd.ct), 0)
