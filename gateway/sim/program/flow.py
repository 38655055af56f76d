"""Jumps of a running program: where they land (§12 JUMP table) and when they are taken.

The landing rules are the ones ``gateway.protocol.program`` checks statically: ``+n`` and
``-n`` count from the statement after the jump (0), ``An`` from the first statement (1),
``G{LB}n`` from the label statement (0). The simulator applies them when the jump is taken,
as the device does: a missing label or a step outside the program is a command error then
(§12 JUMP table), whatever the static checker would have said at upload.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from gateway.protocol.text_params import jump_count
from gateway.sim.dispatch import Refused
from gateway.sim.flags import Error

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

__all__ = ["ERROR_BITS", "compare", "condition", "errors_present", "land"]

#: The condition-flag errors ``/JE``, ``/EC`` and ``/?`` look at: bits 0, 1, 2 (and 6, the
#: step-out latch, kept apart in ``Flags``). Bit 3 is not one of them (§12 /JE 注意).
ERROR_BITS = Error.COMMUNICATION | Error.LIMIT | Error.EMERGENCY


def land(step: int, operand: str, labels: Mapping[str, int], size: int) -> int:
    """The step a jump or call at ``step`` lands on; ``Refused`` when it cannot (§12 JUMP)."""
    count = jump_count(operand)
    kind = operand[0]
    if kind == "+":
        target = step + 1 + count
    elif kind == "-":
        target = step + 1 - count
    elif kind == "A":
        target = count
    else:
        label = operand[1]
        if label not in labels:
            raise Refused(f"no /G{label} in the program (§12 JUMP table)")
        target = labels[label] + count
    if not 1 <= target <= size:
        raise Refused(f"jump to step {target}, outside the program (steps 1-{size})")
    return target


def compare(left: int, sign: str, right: int) -> bool:
    """The ``<``, ``=``, ``>`` of /JC, /JP, /JR (unsigned for buffers, §12 /JR 注意)."""
    if sign == "<":
        return left < right
    if sign == ">":
        return left > right
    return left == right


def errors_present(ctl: ControllerView, bit: int | None = None) -> bool:
    """An error in the condition flags (bits 0, 1, 2, 6 of ``9``), or in one of them."""
    if bit == 6:
        return ctl.flags.step_out
    if bit is not None:
        return bool(ctl.flags.condition & Error(1 << bit))
    return bool(ctl.flags.condition & ERROR_BITS) or ctl.flags.step_out


def _input(ctl: ControllerView, bit: str, t: float) -> bool:
    """``/JO`` bits: 0-7 inputs, 8/9 INP1/INP2, A/B/C the selected motor's ORG/CW/CCW."""
    if bit in "ABC":
        # §12 /JO 注意: the sensors of the motor chosen with F, read when the jump runs.
        sensors = ctl.axes[ctl.selected].sensors(t)
        return {"A": sensors.org, "B": sensors.cw_limit, "C": sensors.ccw_limit}[bit]
    number = int(bit)
    if number >= 8:
        return ctl.rt.inp[number - 8]
    return bool(ctl.rt.inputs >> number & 1)


def _buffer(ctl: ControllerView, name: Any) -> int:
    return ctl.rt.buffers.get(str(name), 0)


def condition(ctl: ControllerView, cmd: Any, t: float) -> tuple[bool, bool]:
    """Whether the jump ``cmd`` is taken at ``t``, and whether that depends on motion.

    The second value tells the machine that the answer can change while a motor turns
    (position, sensors, motion), so a polling loop of such jumps is not skipped then.
    """
    key = cmd.key
    if key in ("/J{jump}", "/SC{jump}"):
        return True, False
    if key.startswith("/JB"):
        bit = _buffer(ctl, cmd.bf) >> int(cmd.bt) & 1
        return bit == (1 if key.startswith("/JBON") else 0), False
    if key == "/JC{ct}{jump}":
        return ctl.rt.counters.get(int(cmd.ct), 0) == 0, False
    if key == "/JC{ct}{sn}{cn}{jump}":
        count = ctl.rt.counters.get(int(cmd.ct), 0)
        return compare(count, str(cmd.sn), int(cmd.cn)), False
    if key == "/JE{jump}":
        return errors_present(ctl), False
    if key == "/JE{bt}{jump}":
        return errors_present(ctl, int(cmd.bt)), False
    if key == "/JM{jump}":
        return ctl.moving_motor(t) is not None, True
    if key in ("/JON{bt}{jump}", "/JOF{bt}{jump}"):
        which = str(cmd.bt)
        on = _input(ctl, which, t)
        return on == (key == "/JON{bt}{jump}"), which in "ABC"
    if key == "/JP{mt}{sn}{pj}{jump}":
        motor = int(cmd.mt)
        # Both sides in the position format in force (§10 EP), as the host would read them.
        here = ctl.position(motor, t)
        return compare(here, str(cmd.sn), ctl.shown(int(cmd.pj))), True
    if key == "/JR{bf}{sn}{du}{dl}{jump}":
        value = int(cmd.du) << 4 | int(cmd.dl)
        return compare(_buffer(ctl, cmd.bf), str(cmd.sn), value), False
    if key == "/JR{bf}{sn}R{b2}{jump}":
        return compare(_buffer(ctl, cmd.bf), str(cmd.sn), _buffer(ctl, cmd.b2)), False
    if key == "/JT{jump}":
        return not ctl.rt.timer.timed_up(t), False
    raise KeyError(f"{key} is not a jump")
