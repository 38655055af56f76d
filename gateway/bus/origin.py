"""What the replies tell about each axis's origin and counter (DESIGN invariant 16).

The RC-233 has no reset flag, no boot message and no reset counter; what a power cycle leaves
that a host can see is (docs/manual-notes.md "How the gateway sees a controller reset"):

* silence: a controller switched off answers nothing. Silence alone is no proof (a noisy line
  makes a controller miss a few polls too), so it only makes every earlier reading not current
  (``StateCache.set_online``): a check reads the position again, and the counters tell;
* its position counters: power-on starts both at 0 (§16: every RAM value at its initial
  value). Two readings of 0 in a row after a reading that was not 0, with nothing the
  gateway knows of that could have changed the counter in between (no motion seen or
  started, no preset, no origin search, no user program running), are a reset
  (``COUNTER_RESTARTED``); one alone could be a reply bent on the line.

An origin search that ends stopped without a limit, emergency or command error (§10 0 ... 0Z:
the counter is 0 at the origin) makes the axis homed; S / SS abandon it (no new origin).

``readings`` calls these with each reply; they write through the same ``StateWriter``.
"""

from __future__ import annotations

from typing import Any, Protocol

from gateway.bus.counting import counter_of, follow_counter
from gateway.bus.state_types import MOTORS, AxisState, ControllerState, Origin
from gateway.protocol import commands
from gateway.protocol.command_text import REGISTRY
from gateway.protocol.models import Command
from gateway.protocol.reply_values import ProgramState, StatusFlags
from gateway.protocol.spec import Effect

__all__ = [
    "COUNTER_RESTARTED",
    "OriginWriter",
    "axis_moving",
    "origin_accepted",
    "origin_position",
    "origin_program",
    "origin_status",
]

#: The cause of a reset concluded from a counter that went to 0 by itself.
COUNTER_RESTARTED = (
    "motor {motor}'s position counter reads 0 after {previous}, and nothing the gateway knows "
    "of moved or preset it: the controller was reset (power-on starts the counters at 0, §16)"
)
#: ``R{pp}``: presets the counter of the selected motor (§10 R).
_PRESET = REGISTRY.form("R{pp}")
_PROGRAM_ACTIVE = (ProgramState.RUNNING, ProgramState.PAUSED)


class OriginWriter(Protocol):
    """What the origin rules read and write (``gateway.bus.state.StateCache``)."""

    def flags(self, loop: str, body: str) -> ControllerState:
        """One controller as last changed."""
        ...

    def axis(self, loop: str, body: str, motor: int) -> AxisState:
        """One axis."""
        ...

    def axis_flags(self, loop: str, body: str, motor: int) -> AxisState:
        """One axis as last changed (its ``updated`` may lag behind: no copy)."""
        ...

    def write_axis(self, now: float, loop: str, body: str, motor: int, **values: Any) -> None:
        """Set fields of one axis."""
        ...

    def controller_reset(
        self, now: float, loop: str, body: str, cause: str, *, read: int | None = None
    ) -> None:
        """A reset of controller ``body`` was seen."""
        ...


def axis_moving(ctl: ControllerState, motor: int) -> bool | None:
    """Whether ``motor`` moves: None while not read, or while a motor moves and which one is
    not known (a status read says that one moves, not which, §10 "", §10 F). The mover is
    the selected motor once the selection is known (read back, or the motor the gateway's
    own motion command named: ``last_moved``); a selection in doubt (a user program selects
    with no frame of the gateway's) names no motor until ``97`` is read (§10 F: F is
    refused while moving, so the selection shows the mover)."""
    if ctl.moving is None:
        return None
    if not ctl.moving:
        return False
    known = ctl.selection_confirmed or ctl.last_moved == ctl.selected_motor
    if ctl.selected_motor is None or not known:
        return None
    return ctl.selected_motor == motor


def origin_position(
    cache: OriginWriter, loop: str, body: str, motor: int, reported: int, now: float
) -> None:
    """A reading ``reported`` of ``motor``'s counter (either view, §10 EP): the position
    followed through wraps (``counting``), the raw counter, and a reset it may reveal."""
    ctl = cache.flags(loop, body)
    axis = cache.axis(loop, body, motor)
    settled = not ctl.moving and not axis.homing
    quiet = settled and not axis.counting and ctl.program not in _PROGRAM_ACTIVE
    zero = quiet and counter_of(reported) == 0
    zero_from: int | None = None
    if zero and axis.zero_from is not None:  # twice 0 by itself: the controller was reset
        cause = COUNTER_RESTARTED.format(motor=motor, previous=axis.zero_from)
        cache.controller_reset(now, loop, body, cause, read=motor)
        axis = cache.axis(loop, body, motor)
    elif zero and axis.counter not in (None, 0):
        zero_from = axis.position if axis.position is not None else axis.counter
    current = axis.position is not None and not axis.stale and axis.position_current
    position = follow_counter(reported, axis.position if current else None)
    cache.write_axis(
        now,
        loop,
        body,
        motor,
        position=position,
        counter=counter_of(reported),
        position_current=True,
        counting=axis.counting and not settled,
        zero_from=zero_from,
        updated=now,
        stale=False,
    )


def origin_accepted(
    cache: OriginWriter, loop: str, body: str, command: Command, motor: int | None, now: float
) -> None:
    """A command taken with '>': motion and presets change the counter, an origin search
    starts, a stop abandons a search (§10 S, SS: no new origin)."""
    form = command.form
    if form.effect is Effect.STOP:
        for m in MOTORS:
            if cache.axis(loop, body, m).homing:
                cache.write_axis(now, loop, body, m, homing=False)
        return
    if motor is None or (form.effect is not Effect.MOTION and form is not _PRESET):
        return
    # A search sent while a motor moves is ignored with a command error (§9-1 注意): no search.
    search = form in commands.ORIGIN_SEARCHES and not cache.flags(loop, body).moving
    cache.write_axis(now, loop, body, motor, counting=True, **({"homing": True} if search else {}))


def origin_status(
    cache: OriginWriter, loop: str, body: str, flags: StatusFlags, now: float
) -> None:
    """A status read (§10 ""): a motor that moves counts; a search that ended stopped without
    a limit or emergency error has found the origin."""
    ctl = cache.flags(loop, body)
    for m in MOTORS:
        axis = cache.axis_flags(loop, body, m)
        if flags.moving:
            if axis_moving(ctl, m) is not False and not axis.counting:
                cache.write_axis(now, loop, body, m, counting=True)
        elif axis.homing:
            # A limit or EMS ends a search without an origin; a command error means it was
            # not taken (§10 "", §9-1 注意).
            found = not (flags.limit_error or flags.emergency_stop or flags.command_error)
            origin = {"origin": Origin.HOMED} if found else {}
            cache.write_axis(now, loop, body, m, homing=False, **origin)


def origin_program(
    cache: OriginWriter, loop: str, body: str, state: ProgramState, now: float
) -> None:
    """A user program runs (``GSS``): it may move either motor, out of the gateway's sight."""
    if state in _PROGRAM_ACTIVE:
        for m in MOTORS:
            if not cache.axis(loop, body, m).counting:
                cache.write_axis(now, loop, body, m, counting=True)
