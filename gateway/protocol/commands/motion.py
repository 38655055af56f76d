"""Constructors of the position, motion, speed and stop forms (§10 2-8, 0*, O*, S, SS)."""

from __future__ import annotations

from gateway.protocol.command_text import REGISTRY
from gateway.protocol.commands.base import (
    SPEED_PARAM,
    HomeMethod,
    SpeedName,
    build,
    for_motor,
    on_off,
)
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat

__all__ = [
    "home",
    "jog_ccw",
    "jog_cw",
    "jog_high",
    "jog_low",
    "move_ccw",
    "move_cw",
    "move_to_position_data",
    "position",
    "position_data",
    "position_format",
    "set_position_data",
    "set_position_format",
    "set_speed",
    "set_table_entry",
    "slow_stop",
    "speed",
    "step_ccw",
    "step_cw",
    "stop",
    "store_position",
    "table_entry",
]


def position(motor: int | None = None) -> Command:
    """``6`` (selected motor) or ``6{mt}`` (motor MT, selection kept): the current position."""
    return for_motor("6", motor)


def position_format() -> Command:
    """``EP``: the position management (EP0 unsigned, EP1 signed)."""
    return build("EP")


def set_position_format(signed: bool) -> Command:
    """``EP1`` (signed) or ``EP0`` (unsigned)."""
    return on_off("EP", signed)


def set_position_data(
    pulses: int, positions: PositionFormat | None = None, *, signed: bool | None = None
) -> Command:
    """``2{pp}``: the position data of 3, 4 and 5.

    ``positions``: the controller's management, checked when given; signed management (or a
    negative count) writes a sign. ``signed`` forces or forbids the sign.
    """
    values: dict[str, object] = {"pp": pulses}
    if signed is not None:
        values["signed"] = signed
    return REGISTRY.build("2{pp}", values, positions)


def position_data() -> Command:
    """``2D``: the position data set with ``2``."""
    return build("2D")


def table_entry(number: int) -> Command:
    """``A{pn}D``: entry ``number`` (0-999) of the position table."""
    return build("A{pn}D", pn=number)


def set_table_entry(
    number: int, pulses: int, positions: PositionFormat | None = None, *, signed: bool | None = None
) -> Command:
    """``A{pn}{pp}``: entry ``number`` of the position table; signs as ``set_position_data``."""
    values: dict[str, object] = {"pn": number, "pp": pulses}
    if signed is not None:
        values["signed"] = signed
    return REGISTRY.build("A{pn}{pp}", values, positions)


def store_position(number: int) -> Command:
    """``A{pn}``: entry ``number`` of the position table to the selected motor's position."""
    return build("A{pn}", pn=number)


def move_to_position_data(motor: int | None = None) -> Command:
    """``3`` / ``3{mt}``: move to the position set with ``2``."""
    return for_motor("3", motor)


def move_cw(motor: int | None = None) -> Command:
    """``4`` / ``4{mt}``: move CW by the pulse count set with ``2``."""
    return for_motor("4", motor)


def move_ccw(motor: int | None = None) -> Command:
    """``5`` / ``5{mt}``: move CCW by the pulse count set with ``2``."""
    return for_motor("5", motor)


def home(method: HomeMethod = "0") -> Command:
    """An origin search of the selected motor (§10 0, 0A, 0H, 0R, 0Z)."""
    return build(method)


def jog_cw(motor: int | None = None) -> Command:
    """``7`` / ``7{mt}``: rotate CW at Low speed until stopped."""
    return for_motor("7", motor)


def jog_ccw(motor: int | None = None) -> Command:
    """``8`` / ``8{mt}``: rotate CCW at Low speed until stopped."""
    return for_motor("8", motor)


def jog_high() -> Command:
    """``H``: raise a 7/8 jog to High speed."""
    return build("H")


def jog_low() -> Command:
    """``L``: lower a 7/8 jog to Low speed."""
    return build("L")


def step_cw() -> Command:
    """``7*``: one pulse CW."""
    return build("7*")


def step_ccw() -> Command:
    """``8*``: one pulse CCW."""
    return build("8*")


def stop() -> Command:
    """``S``: stop the motor at once."""
    return build("S")


def slow_stop() -> Command:
    """``SS``: decelerate to Low speed, then stop."""
    return build("SS")


def speed(name: SpeedName) -> Command:
    """The query form of one speed setting (``OH``, ``OL``, ``OS``, ``OC``, ``OX``)."""
    return build(name)


def set_speed(name: SpeedName, value: int) -> Command:
    """The setting form of one speed (``OH{hs}``, ``OL{ls}``, ``OS{ss}``, ``OC{dt}``,
    ``OX{xs}``), each checked against its own range."""
    param = SPEED_PARAM[name]
    return REGISTRY.build(f"{name}{{{param}}}", {param: value})
