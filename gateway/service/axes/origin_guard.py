"""Moves that need the origin: refused while it is lost, checked against a fresh reading.

A controller reset restarts the position counters at 0 wherever the axes stand (§16), so a
target in user units or inside soft limits means nothing until the axis is homed again
(DESIGN invariant 16). The state cache decides when the origin is lost
(``gateway.bus.origin``); here the service refuses what depends on it:

* while an axis's origin is lost, an absolute move in user units and every move of an axis
  with soft limits are refused 409 with the rule ``HOME_FIRST_RULE``; origin searches and
  stops pass;
* such a move reads the position first (``6{mt}``, one exchange; two when it reads 0 by
  itself), so a reset not seen yet is seen now, before anything moves, and its checks use a
  reading no older than the controller's last reset or reconnect.

At gateway start the origin is unknown (never homed as far as this process knows): moves are
not refused then (docs/api-notes.md "Homed, origin lost").
"""

from __future__ import annotations

from gateway.bus.state_types import AxisState, Origin
from gateway.errors import ConflictError, DeviceError
from gateway.protocol import commands as cmd
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import AxisRef

__all__ = ["HOME_FIRST_RULE", "OriginGuard", "needs_origin", "reading_is_current"]

#: The rule a move breaks when it needs an origin that is lost.
HOME_FIRST_RULE = (
    "home first: after a controller reset the origin is lost; absolute moves in user units "
    "and every move of an axis with soft limits are refused until an origin search "
    "(POST /axes/{id}/home) ends; homing and stops pass"
)


def needs_origin(ref: AxisRef, *, absolute_user: bool) -> bool:
    """Whether a move of ``ref`` depends on the origin: an absolute target in user units, or
    any move of an axis with soft limits."""
    return absolute_user or ref.soft_min is not None or ref.soft_max is not None


def reading_is_current(axis: AxisState) -> bool:
    """A position reading a check may use: fresh, and not older than the last reset or
    reconnect of its controller."""
    return axis.position is not None and not axis.stale and axis.position_current


class OriginGuard:
    """The origin check of the moves that need it."""

    def __init__(self, runtime: Runtime) -> None:
        self.runtime = runtime

    def check(self, ref: AxisRef, what: str, field: str = "axis") -> None:
        """Refuse (409, ``HOME_FIRST_RULE``) when ``ref``'s origin is lost."""
        ctl = self.runtime.state.controller(ref.loop, ref.body)
        axis = self.runtime.state.axis(ref.loop, ref.body, ref.motor)
        if axis.origin is Origin.LOST:
            cause = f" ({ctl.reset_cause})" if ctl.reset_cause else ""
            raise ConflictError(
                f"cannot {what} axis {ref.id}: its origin is lost, controller "
                f"{ref.controller_id} was reset{cause}; home it first",
                field=field,
                rule=HOME_FIRST_RULE,
            )

    async def confirm(self, ref: AxisRef, what: str, field: str = "axis") -> int:
        """Read ``ref``'s position now (a reset shows in it, ``gateway.bus.origin``), refuse
        the move if the origin is lost, and return the position read (pulses, followed
        through the counter's wraps)."""
        self.check(ref, what, field)
        scheduler = self.runtime.scheduler(ref.loop)
        result = await scheduler.submit(ref.body, [cmd.position(ref.motor)], motor=None)
        axis = self.runtime.state.axis(ref.loop, ref.body, ref.motor)
        if axis.zero_from is not None:  # 0 by itself: once more, to tell a reset from noise
            result = await scheduler.submit(ref.body, [cmd.position(ref.motor)], motor=None)
            axis = self.runtime.state.axis(ref.loop, ref.body, ref.motor)
        self.check(ref, what, field)
        if not isinstance(result.value, int) or axis.position is None:
            raise DeviceError(
                f"the position of {ref.id} could not be read, so its origin and limits cannot "
                "be checked; nothing was sent",
                outcome="not_done",
            )
        return axis.position
