"""The chapter-12 statements a program runs: waits, jumps, buffers, counters, messages, timer.

``execute`` carries out one statement on the controller at simulated time ``t`` and tells the
machine what follows through its fields (``jump_to``, ``wait``, ``pure``, ``end``). It raises
``Refused`` for a command error (the machine then ends the program with E, §10 GSS).
Data buffers A-F are single bytes, counters 1 and 2 run 0-65,535 (§12, §10 GW).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from gateway.protocol.command_text import parse
from gateway.sim.actions import stop_moving, write_eeprom
from gateway.sim.dispatch import HANDLERS, Refused
from gateway.sim.program import flow
from gateway.sim.program.output import buffer_message, counter_message, text_message
from gateway.sim.program.timing import MAX_CALLS, StatementRun, Wait, start_timer

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

__all__ = ["execute"]

#: Jumps and calls: their landing step is worked out only when they are taken.
_JUMPS = frozenset(
    {
        "/J{jump}",
        "/JBON{bf}{bt}{jump}",
        "/JBOF{bf}{bt}{jump}",
        "/JC{ct}{jump}",
        "/JC{ct}{sn}{cn}{jump}",
        "/JE{jump}",
        "/JE{bt}{jump}",
        "/JM{jump}",
        "/JON{bt}{jump}",
        "/JOF{bt}{jump}",
        "/JP{mt}{sn}{pj}{jump}",
        "/JR{bf}{sn}{du}{dl}{jump}",
        "/JR{bf}{sn}R{b2}{jump}",
        "/JT{jump}",
        "/SC{jump}",
    }
)
_COUNTER_MAX = 65535


def execute(m: StatementRun, ctl: ControllerView, cmd: Any, t: float) -> None:
    """Carry out the program-only statement ``cmd`` (§12)."""
    key: str = cmd.key
    if key in _JUMPS:
        _jump(m, ctl, cmd, t)
    elif key == "/":
        # §12 / (NULL): wait while a motor turns; /TS adds its stop wait after every NULL.
        if ctl.moving_motor(t) is not None or m.stop_wait:
            m.wait = Wait.MOTION
        else:
            m.pure = True
    elif key == "/G{lb}":
        m.pure = True  # a label does nothing (§12 /G)
    elif key == "/SR":
        if not m.calls:
            raise Refused("/SR without /SC")
        m.jump_to = m.calls.pop()
    elif key == "/END":
        ctl.rt.step = m.current  # §10 GN: after /END, GN names the /END itself
        m.end(ctl)
    elif key == "/?":
        if flow.errors_present(ctl):
            # §12 /?, §11-4 example 3: the motor stops at once and the program ends there.
            stop_moving(ctl, t)
            ctl.rt.step = m.current
            m.end(ctl)
    elif key in ("/T{dt}", "/TB{dt}", "/TS{dt}"):
        _timer(m, ctl, key, int(cmd.dt), t)
    elif key in ("/WAW", "/WDW"):
        # §12 /WAW, /WDW: AW or DW, then wait for the end of the write. A program's general
        # commands send nothing to the host (§11-3), so no $B#* either.
        m.until = t + write_eeprom(ctl, "AW" if key == "/WAW" else "DW")
        m.wait = Wait.UNTIL
    elif key.startswith(("/CS", "/CU", "/CD", "/CC")):
        _counter(ctl, cmd, t)
    elif key.startswith("/CO"):
        ctl.emit(t, text_message(ctl, str(cmd.dt)))
    elif key.startswith("/EC"):
        _clear_errors(ctl, cmd)
    elif key == "/O{pt}{bf}":
        _out(ctl, cmd, t)
    else:
        _buffer_op(ctl, cmd, t)


def _jump(m: StatementRun, ctl: ControllerView, cmd: Any, t: float) -> None:
    taken, m.reads_motion = flow.condition(ctl, cmd, t)
    call = cmd.key == "/SC{jump}"
    m.pure = not call
    if not taken:
        return
    target = flow.land(m.current, str(cmd.jump), m.labels, m.size)
    if call:
        if len(m.calls) >= MAX_CALLS:
            raise Refused(f"more than {MAX_CALLS} nested /SC (§12 /SC)")
        m.calls.append(m.current + 1)
    m.jump_to = target


def _timer(m: StatementRun, ctl: ControllerView, key: str, tenths: int, t: float) -> None:
    if key == "/TS{dt}":
        m.stop_wait = tenths  # used after each NULL from now on (§12 /TS)
        return
    start_timer(ctl, tenths, t)
    if key == "/T{dt}":
        m.wait = Wait.TIMER  # §12 /T: wait for time-up; /TB goes on at once (for /JT)


def _counter(ctl: ControllerView, cmd: Any, t: float) -> None:
    counters = ctl.rt.counters
    ct = int(cmd.ct)
    count = counters.get(ct, 0)
    if cmd.key == "/CS{ct},{cn}":
        counters[ct] = int(cmd.cn)
    elif cmd.key == "/CU{ct}":
        counters[ct] = min(count + 1, _COUNTER_MAX)  # stays at 65535 (§12 /CU)
    elif cmd.key == "/CD{ct}":
        counters[ct] = max(count - 1, 0)  # stays at 0 (§12 /CD)
    else:
        ctl.emit(t, counter_message(ctl, ct, count))


def _clear_errors(ctl: ControllerView, cmd: Any) -> None:
    """§12 /EC: bits 0, 1, 2, 6 of the condition flags (all, or the one named) to 0."""
    flags = ctl.flags
    if cmd.key == "/EC":
        flags.condition &= ~flow.ERROR_BITS
        flags.step_out = False
        return
    bit = int(cmd.bt)
    if bit == 6:
        flags.step_out = False
    else:
        flags.condition &= ~type(flags.condition)(1 << bit)


def _out(ctl: ControllerView, cmd: Any, t: float) -> None:
    value = ctl.rt.buffers.get(str(cmd.bf), 0)
    if int(cmd.pt) == 3:
        ctl.emit(t, buffer_message(ctl, value))
        return
    # PT 1: the byte to the output port, through D so that a P pulse is kept track of.
    HANDLERS["D{du}{dl}"](ctl, parse(f"D{value:02X}"), t)


def _buffer_op(ctl: ControllerView, cmd: Any, t: float) -> None:
    """/AND, /OR, /LD, /BS, /RR, /RL, /I1, /IL: one byte buffer A-F (§12)."""
    buffers = ctl.rt.buffers
    name = str(cmd.bf)
    value = buffers.get(name, 0)
    params = cmd.model_dump()
    if "b2" in params:
        operand = buffers.get(str(cmd.b2), 0)
    elif "du" in params:
        operand = int(cmd.du) << 4 | int(cmd.dl)
    else:
        operand = 0
    mnemonic = cmd.spec.mnemonic
    if mnemonic == "/AND":
        value &= operand
    elif mnemonic == "/OR":
        value |= operand
    elif mnemonic == "/LD":
        value = operand
    elif mnemonic == "/BS":
        bit = 1 << int(cmd.bt)
        value = value | bit if int(cmd.dt) else value & ~bit
    elif mnemonic == "/RR":
        value = value >> 1 | (value & 1) << 7
    elif mnemonic == "/RL":
        value = (value << 1 | value >> 7) & 0xFF
    elif mnemonic == "/I1":
        value = ctl.rt.inputs  # §12 /I1: the general input port
    elif mnemonic == "/IL":
        # §12 /IL: what CL reports (the sensors of the selected motor, EMS included).
        value = HANDLERS["CL"](ctl, cmd, t).byte  # type: ignore[attr-defined]
    else:
        raise KeyError(f"{cmd.key} has no simulator behaviour")
    buffers[name] = value & 0xFF
