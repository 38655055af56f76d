"""EEPROM commands: §10 AW, DW, IW (write, then ``$B#*``), AL, DL, IL (load), EE/// (erase).

A write takes its data at the command and answers ``>`` at once; ``$B#*`` follows when the
write time has passed (``eeprom.WRITE_SECONDS``). ``EE///`` answers ``>`` and then stays silent
for the erase time before its ``$B#*`` (§10 EE///). Loading what was never written copies the
factory values (§10 AL, DL).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from gateway.protocol.framing import EEPROM_DONE
from gateway.sim.actions import write_eeprom
from gateway.sim.dispatch import handles
from gateway.sim.eeprom import ERASE_SECONDS, WRITE_SECONDS
from gateway.sim.memory import POSITION_TABLE_SIZE, Settings

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView


def _written(ctl: ControllerView, key: str, now: float) -> None:
    ctl.later(WRITE_SECONDS[key], EEPROM_DONE, now)


@handles("DW")
def write_settings(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 DW: every DW target of both motors to EEPROM."""
    ctl.later(write_eeprom(ctl, "DW"), EEPROM_DONE, now)


@handles("AW")
def write_table(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 AW: the 1000 A entries to EEPROM."""
    ctl.later(write_eeprom(ctl, "AW"), EEPROM_DONE, now)


@handles("IW")
def write_program(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 IW: the RAM user program to EEPROM."""
    ctl.eeprom.write("iw", ctl.rt.program)
    _written(ctl, "IW", now)


@handles("DL")
def load_settings(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 DL: the DW targets from EEPROM (factory values if DW never ran).

    RAM-only settings (the N points, QSE) are not DW targets and keep their values. The reply
    to DL is written in the framing DL loaded (docs/manual-notes.md "DL and framing").
    """
    image = ctl.eeprom.image.dw
    loaded = Settings.from_dw_image(image) if image else Settings()
    shared = ctl.settings.shared
    loaded.shared.points = shared.points
    loaded.shared.points_on = shared.points_on
    loaded.shared.encoder_step_out = shared.encoder_step_out
    ctl.settings = loaded
    for n, axis in ctl.axes.items():
        axis.logic = loaded.motors[n].logic


@handles("AL")
def load_table(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 AL: the A entries from EEPROM (all 0 if AW never ran)."""
    image = ctl.eeprom.image.aw
    ctl.table = list(image) if image else [0] * POSITION_TABLE_SIZE


@handles("IL")
def load_program(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 IL: the RAM program replaced by the IW copy (empty if IW never ran)."""
    ctl.rt.program = ctl.eeprom.image.iw or ""


@handles("EE///")
def erase(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 EE///: erase everything AW, DW, IW, GA and ES wrote; silent until ``$B#*``.

    RAM keeps its values: the factory settings come back at the next power-on (§10 EE///).
    """
    ctl.eeprom.erase()
    ctl.busy(now + ERASE_SECONDS, now)
