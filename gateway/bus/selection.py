"""Motor selection (§9-1, §10 F): how the scheduler learns which motor each controller acts on.

A controller drives two motors; commands without a motor suffix, and every per-motor setting,
act on the motor ``F`` selected. The scheduler owns the selection (DESIGN invariant 5): a
per-motor command for motor m goes inside its transaction with ``F{m}`` first whenever the
known selection is not m, and the selection is dropped after any doubt (time-out, garbled
reply, '?', reconnect), so that F is sent again rather than trusted.

The selection has one home, the state cache (``ControllerState.selected_motor``, trusted by
the scheduler only while ``selection_confirmed``): the scheduler publishes what it learns as
``SelectionChanged`` and reads it back from there (``LineExchange.selected``). It learns from:
* ``F{m}`` answered '>' and, unless ER1 would have said '>@', confirmed with ``97`` (bit 7 of
  the condition flags: the selected motor, §10 9; it clears nothing). F is refused while a
  motor moves (§10 F, 動作中 ×) with the same bare '>': without the confirmation a motor-2
  setting would land on motor 1.
* a motion command with a suffix (``4{mt}`` ...): selects that motor when it is executed
  (§9-1, §10 F), but a refused one (moving, EMS) keeps the old selection with the same '>'
  (docs/manual-notes.md "Order of the checks"). So the suffix is trusted only with ER1,
  where '>' means executed; otherwise the selection is forgotten (``after_accepted``).
* replies that show the selection: ``9`` (bit 7), ``97``, ``F``.

Stops need no F: the selected motor is the moving one (F is refused while moving, and a suffix
selects the motor it starts), and §10 F lists S and SS among the commands acting on the selected
motor.
"""

from __future__ import annotations

import functools

from gateway.protocol import commands
from gateway.protocol.framing import Framing
from gateway.protocol.models import Command
from gateway.protocol.replies import ReplyValue
from gateway.protocol.reply_values import ConditionFlags
from gateway.protocol.spec import Scope

__all__ = [
    "after_accepted",
    "confirm_command",
    "needs_selection",
    "select_command",
    "selection_from_reply",
]

#: §10 9 form II: bit 7 = the selected motor (0 = motor 1, 1 = motor 2); clears nothing.
_SELECTED_BIT = 7


def needs_selection(command: Command) -> bool:
    """Whether ``command`` acts on the selected motor (per-motor, no motor parameter, no stop)."""
    return (
        command.spec.scope is Scope.PER_MOTOR
        and command.form.motor_param is None
        and not command.form.is_stop
    )


@functools.cache  # command models are frozen: one model serves every selection
def select_command(motor: int) -> Command:
    """``F{motor}``."""
    return commands.select_motor(motor)


@functools.cache
def confirm_command() -> Command:
    """``97``: the selected-motor bit of the condition flags."""
    return commands.condition_bit(_SELECTED_BIT)


def selection_from_reply(command: Command, value: ReplyValue | None) -> int | None:
    """The selected motor a reply shows, or None when it shows none."""
    if value is None or isinstance(value, bool):
        return None
    if command.form is commands.CONDITION and isinstance(value, ConditionFlags):
        return value.selected_motor
    if command.form is commands.CONDITION_BIT and int(command.params()["bit"]) == _SELECTED_BIT:
        return 2 if value == 1 else 1 if value == 0 else None
    if command.form is commands.SELECTED_MOTOR and value in (1, 2):
        return int(value)
    return None


def after_accepted(command: Command, framing: Framing) -> int | bool | None:
    """What a command answered '>' (not '>@') tells of the selection.

    The newly selected motor, None when the selection is not known any more, False when the
    command says nothing about the selection.
    """
    if not command.form.selects_motor:
        return False
    motor = command.motor
    # F is confirmed by the caller (97) unless ER1; a suffix is executed under ER1.
    if (command.form is commands.SELECT_MOTOR or framing.error_mark) and motor is not None:
        return motor
    return None
