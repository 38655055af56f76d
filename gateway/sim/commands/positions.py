"""Position data, the A table, presets and position queries: §10 2, A, R, 6, B (BN).

Stored positions are kept as 24-bit counter values and shown in the format in force (§10 EP
table: the two formats are two views of one counter), so ``EP`` changes how a stored value
reads, never the value itself.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from gateway.protocol.params import UNSIGNED_MAX
from gateway.sim.dispatch import handles

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

_MASK = UNSIGNED_MAX  # 0xFFFFFF: a 24-bit counter


@handles("2{pp}")
def set_position_data(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 2 form I: the position data used by 3, 4 and 5 (shared)."""
    ctl.settings.shared.position_data = int(cmd.pp) & _MASK


@handles("2")
def store_position_data(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 2 form II: the selected motor's current position becomes the position data.

    While a motor moves, the position it started from (§10 2 注意点).
    """
    moving = ctl.moving_motor(now)
    if moving is not None:
        ctl.settings.shared.position_data = ctl.axes[moving].start_counter & _MASK
    else:
        ctl.settings.shared.position_data = ctl.axes[ctl.selected].counter(now) & _MASK


@handles("2D")
def position_data(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 2 form III: the position data."""
    return ctl.shown(ctl.settings.shared.position_data)


@handles("A{pn}{pp}")
def set_entry(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 A form I: one entry of the 1000-point table (shared)."""
    ctl.table[int(cmd.pn)] = int(cmd.pp) & _MASK


@handles("A{pn}")
def store_entry(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 A form II: the selected motor's current position becomes entry pn."""
    ctl.table[int(cmd.pn)] = ctl.axes[ctl.selected].counter(now) & _MASK


@handles("A{pn}D")
def entry(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 A form III: entry pn."""
    return ctl.shown(ctl.table[int(cmd.pn)])


@handles("R")
def zero_here(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 R form I: the current position of the selected motor becomes 0."""
    ctl.axes[ctl.selected].preset(now, 0)


@handles("R{pp}")
def preset(ctl: ControllerView, cmd: Any, now: float) -> None:
    """§10 R form II: the current position of the selected motor becomes pp."""
    ctl.axes[ctl.selected].preset(now, int(cmd.pp))


@handles("6", "6{mt}")
def position(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 6: the current position; ``6{mt}`` does not change the selection (§10 F)."""
    motor = int(cmd.mt) if cmd.motor is not None else ctl.selected
    return ctl.position(motor, now)


@handles("BN")
def next_entry(ctl: ControllerView, cmd: Any, now: float) -> int:
    """§10 B form V: the entry the next sequential B uses; 00000 after power-on."""
    return ctl.rt.next_entry or 0
