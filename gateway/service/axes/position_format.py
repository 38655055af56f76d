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

from gateway.errors import InvalidInputError
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import AxisRef

__all__ = ["PositionFormats", "check_target", "position_data"]


class PositionFormats:
    """The position management of every controller, read from the device when not known."""

    def __init__(self, gateway: Runtime) -> None:
        self.gateway = gateway

    def known(self, loop: str, body: str) -> PositionFormat | None:
        """The format if known without asking the device (the state cache keeps EP)."""
        ctl = self.gateway.state.controller(loop, body)
        if ctl.mode == 1:
            return PositionFormat.SIGNED  # mode 1 is always signed, EP ignored (§10 EP)
        if ctl.signed_positions is None:
            return None
        return PositionFormat.SIGNED if ctl.signed_positions else PositionFormat.UNSIGNED

    async def get(self, loop: str, body: str) -> PositionFormat:
        """The format, read with ``EP`` when not known (raises what ``submit`` raises)."""
        fmt = self.known(loop, body)
        if fmt is None:
            await self.gateway.scheduler(loop).submit(body, cmd.position_format())
            # The reply taught the state cache (it hears every reply first).
            fmt = self.known(loop, body)
        # No answer: the move's own checks still hold; assume the power-on EP0.
        return PositionFormat.UNSIGNED if fmt is None else fmt


def check_target(ref: AxisRef, target: int, fmt: PositionFormat) -> None:
    """Refuse a target outside the soft limits, the counter, or the controller's format."""
    ref.check_target(target, "body.position")
    if fmt is PositionFormat.UNSIGNED and target < 0:
        raise InvalidInputError(
            f"target {target} pulses is negative, and controller {ref.controller_id} "
            "manages positions unsigned (EP0)",
            field="body.position",
            rule="negative positions need signed management: EP1 or mode 1 (§10 EP, §7-4)",
        )


def position_data(pulses: int, fmt: PositionFormat) -> Command:
    """``2{pp}``: signed management writes the sign, unsigned never (docs/manual-notes.md)."""
    return cmd.set_position_data(pulses, fmt, signed=fmt is PositionFormat.SIGNED)
