"""What a host command and a user-program statement both do: stop the moving motor, write the
EEPROM. Kept apart from ``sim.commands`` (the host's handlers) and ``sim.program`` (the
interpreter) so that neither has to import the other.
"""

from __future__ import annotations

from gateway.sim.controller_view import ControllerView
from gateway.sim.eeprom import WRITE_SECONDS

__all__ = ["stop_moving", "write_eeprom"]


def stop_moving(ctl: ControllerView, now: float) -> None:
    """§10 S: stop at once. The motor that moves is stopped, whichever is selected."""
    motor = ctl.moving_motor(now)
    if motor is not None:
        ctl.axes[motor].stop(now)


def write_eeprom(ctl: ControllerView, key: str) -> float:
    """Write the ``AW`` or ``DW`` area now; the seconds the write takes (``$B#*`` then).

    The program's ``/WAW`` and ``/WDW`` use it too, and wait that long instead (§12 /WAW).
    """
    if key == "DW":
        ctl.eeprom.write("dw", ctl.settings.dw_image())
    else:
        ctl.eeprom.write("aw", list(ctl.table))
    return WRITE_SECONDS[key]
