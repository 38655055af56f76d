"""How each controller manages positions: unsigned (EP0) or signed (EP1, or mode 1).

A target is written with a sign in signed management and without one in unsigned management
(docs/manual-notes.md "Positions in signed management carry a sign"), and a negative target
exists only in signed management (§10 EP, §7-4: in EP0 moving to -2000 gives 16,775,216 and
position management breaks). The state cache keeps EP (``ControllerState.signed_positions``,
from every ``EP``/``EP0``/``EP1`` reply, forgotten when the link comes back, the controller comes
back online or ``DL`` reloads the settings); mode 1 is always signed (§10 EP). When it is not
known, ``EP`` is read once (refused while moving, and in mode 1).
"""

from __future__ import annotations

from gateway.bus.counting import counter_of, target_range, target_range_rule
from gateway.errors import InvalidInputError
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import AxisRef

__all__ = ["PositionFormats", "check_absolute_from", "check_target", "position_data"]


class PositionFormats:
    """The position management of every controller, read from the device when not known."""

    def __init__(self, runtime: Runtime) -> None:
        self.runtime = runtime

    def known(self, loop: str, body: str) -> PositionFormat | None:
        """The format if known without asking the device (the state cache keeps EP)."""
        ctl = self.runtime.state.controller(loop, body)
        if ctl.mode == 1:
            return PositionFormat.SIGNED  # mode 1 is always signed, EP ignored (§10 EP)
        if ctl.signed_positions is None:
            return None
        return PositionFormat.SIGNED if ctl.signed_positions else PositionFormat.UNSIGNED

    async def get(self, loop: str, body: str) -> PositionFormat:
        """The format, read with ``EP`` when not known (raises what ``submit`` raises)."""
        fmt = self.known(loop, body)
        if fmt is None:
            await self.runtime.scheduler(loop).submit(body, cmd.position_format())
            # The reply taught the state cache (it hears every reply first).
            fmt = self.known(loop, body)
        # No answer: the move's own checks still hold; assume the power-on EP0.
        return PositionFormat.UNSIGNED if fmt is None else fmt


def check_target(ref: AxisRef, target: int, fmt: PositionFormat) -> None:
    """Refuse a target the counter cannot reach without wrapping in the controller's format
    (``gateway.bus.counting``: every target the format writes is allowed), or outside the
    soft limits."""
    low, high = target_range(fmt)
    if target < 0 and fmt is PositionFormat.UNSIGNED:
        raise InvalidInputError(
            f"target {target} pulses is negative, and controller {ref.controller_id} "
            "manages positions unsigned (EP0): the counter would wrap below 0",
            field="position",
            rule=f"{target_range_rule(fmt)}; negative positions need signed management: EP1 "
            "or mode 1",
        )
    if not low <= target <= high:
        raise InvalidInputError(
            f"target {target} pulses is beyond the position counter of controller "
            f"{ref.controller_id}: it would wrap",
            field="position",
            rule=target_range_rule(fmt),
        )
    ref.check_target(target, "position")


def check_absolute_from(ref: AxisRef, here: int | None, fmt: PositionFormat) -> None:
    """Refuse an absolute move from a counter that wrapped below 0 in unsigned management:
    the controller moves by target - counter, the long way round (§7-4 "a later absolute
    move may never stop")."""
    if fmt is PositionFormat.UNSIGNED and here is not None and here < 0:
        raise InvalidInputError(
            f"axis {ref.id} stands at {here} pulses, a counter wrapped below 0 in unsigned "
            f"management (it reads {counter_of(here)}): an absolute move would travel "
            f"{counter_of(here)} pulses the wrong way",
            field="position",
            rule="in unsigned management (EP0) an absolute move needs a position >= 0: home "
            "the axis, or move relative (§7-4, §10 EP)",
        )


def position_data(pulses: int, fmt: PositionFormat) -> Command:
    """``2{pp}``: signed management writes the sign, unsigned never (docs/manual-notes.md)."""
    return cmd.set_position_data(pulses, fmt, signed=fmt is PositionFormat.SIGNED)
