"""What every command constructor shares: argument types and the one way a model is built."""

from __future__ import annotations

from typing import Literal

from gateway.protocol.command_text import REGISTRY
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat

__all__ = [
    "SPEED_PARAM",
    "BaudCode",
    "HomeMethod",
    "ProgramBuffer",
    "SpeedName",
    "build",
    "for_motor",
    "on_off",
]

#: The speed data of one motor: High, Low, acceleration, S-curve rate, multiplier (§10 O*).
SpeedName = Literal["OH", "OL", "OS", "OC", "OX"]
#: §10 ES: 0 = 9600, 1 = 1200, 2 = 300 bps.
BaudCode = Literal[0, 1, 2]
#: The origin searches a host starts on the selected motor (§10 0, 0A, 0H, 0R, 0Z).
HomeMethod = Literal["0", "0A", "0H", "0R", "0Z"]
#: The user program's data buffers (§10 GR).
ProgramBuffer = Literal["A", "B", "C", "D", "E", "F"]

# The parameter each setting form of a speed names (§10 OH{hs}, OL{ls}, OS{ss}, OC{dt}, OX{xs}).
SPEED_PARAM = {"OH": "hs", "OL": "ls", "OS": "ss", "OC": "dt", "OX": "xs"}


def build(key: str, positions: PositionFormat | None = None, **values: object) -> Command:
    """The model of form ``key`` with these parameter values (what ``parse`` builds)."""
    return REGISTRY.build(key, values, positions)


def on_off(mnemonic: str, on: bool) -> Command:
    """The ``1`` (on) or ``0`` (off) form of a switch (``EE1``, ``SUM0``, ``EP1``)."""
    return build(f"{mnemonic}{1 if on else 0}")


def for_motor(key: str, motor: int | None) -> Command:
    """The plain form (selected motor) or its ``{mt}`` form (select MT and act on it)."""
    return build(key) if motor is None else build(f"{key}{{mt}}", mt=motor)
