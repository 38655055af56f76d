"""How each controller manages positions: unsigned (EP0) or signed (EP1, or mode 1).

A target is written with a sign in signed management and without one in unsigned management
(docs/manual-notes.md "Positions in signed management carry a sign"), and a negative target
exists only in signed management (§10 EP, §7-4: in EP0 moving to -2000 gives 16,775,216 and
position management breaks). The state cache does not keep EP, so it is learnt here: mode 1 is
always signed (§10 EP); otherwise ``EP`` is read once (refused while moving, and in mode 1) and
kept, updated from every ``EP``/``EP0``/``EP1`` reply the scheduler publishes, and forgotten
when the link comes back, the controller comes back online or ``DL`` reloads the settings.
"""

from __future__ import annotations

from gateway.bus.events import BusEvent, LinkUp, ReplyObserved
from gateway.bus.state_types import Change
from gateway.errors import InvalidInputError
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.protocol.registry import parse
from gateway.service.gateway import Gateway
from gateway.service.topology import AxisRef

__all__ = ["PositionFormats", "check_target", "position_data"]


class PositionFormats:
    """The position management of every controller, read from the device when not known."""

    def __init__(self, gateway: Gateway) -> None:
        self.gateway = gateway
        self._known: dict[tuple[str, str], PositionFormat] = {}
        for scheduler in gateway.schedulers.values():
            scheduler.events.subscribe(self._on_bus)
        gateway.state.listen(self._on_change)

    def known(self, loop: str, body: str) -> PositionFormat | None:
        """The format if known without asking the device."""
        if self.gateway.state.controller(loop, body).mode == 1:
            return PositionFormat.SIGNED  # mode 1 is always signed, EP ignored (§10 EP)
        return self._known.get((loop, body))

    async def get(self, loop: str, body: str) -> PositionFormat:
        """The format, read with ``EP`` when not known (raises what ``submit`` raises)."""
        fmt = self.known(loop, body)
        if fmt is None:
            result = await self.gateway.scheduler(loop).submit(body, parse("EP"))
            if result.value == 1:
                fmt = PositionFormat.SIGNED
            elif result.value == 0:
                fmt = PositionFormat.UNSIGNED
            else:  # no answer: the move's own checks still hold; assume the power-on EP0
                return PositionFormat.UNSIGNED
            self._known[loop, body] = fmt
        return fmt

    def _on_bus(self, event: BusEvent) -> None:
        if isinstance(event, LinkUp):
            for known in [k for k in self._known if k[0] == event.loop]:
                del self._known[known]
        elif isinstance(event, ReplyObserved) and not event.rejected:
            key, where = event.command.key, (event.loop, event.body)
            if key in ("EP0", "EP1") and event.value is None:
                self._known[where] = (
                    PositionFormat.SIGNED if key == "EP1" else PositionFormat.UNSIGNED
                )
            elif key == "EP" and event.value in (0, 1):
                self._known[where] = (
                    PositionFormat.SIGNED if event.value == 1 else PositionFormat.UNSIGNED
                )
            elif key == "DL" and event.value is None:  # settings reloaded from EEPROM (§10 DL)
                self._known.pop(where, None)

    def _on_change(self, change: Change) -> None:
        if change.body is not None and change.motor is None and "online" in change.values:
            self._known.pop((change.loop, change.body), None)  # power cycle: EP from EEPROM


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
    text = f"2{pulses:+d}" if fmt is PositionFormat.SIGNED else f"2{pulses}"
    return parse(text, positions=fmt)
