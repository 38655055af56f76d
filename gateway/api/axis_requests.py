"""The request bodies of the axis routes (``extra="forbid"``: an unknown field is a 422).

Strict (``strict=True``): a number is a JSON number and a boolean a JSON boolean, never
``"5"`` or ``true`` for a position. Enum fields keep pydantic's lax mode, which takes their
JSON strings (their values) and nothing else; strict mode would ask for Python enum members.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, Strict

from gateway.service.operations.terms import Direction, HomeMethod, JogSpeed, StopMode, Unit
from gateway.service.runtime.bus_types import ErrorKind

__all__ = ["AckRequest", "HomeRequest", "JogRequest", "MoveRequest", "StepRequest", "StopRequest"]


class _Body(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class MoveRequest(_Body):
    """A move to a position, or by a distance."""

    position: float = Field(
        description="target (or distance when relative), in `unit`", allow_inf_nan=False
    )
    relative: bool = Field(False, description="move by `position` from where the axis is")
    unit: Unit = Field(
        strict=False,
        description="required, never assumed: `pulse` (controller pulses) or `user` (the "
        "axis's configured unit: mm, deg ...; see the axis's `unit`)",
    )


class HomeRequest(_Body):
    """An origin search (§10 0, 0A, 0H, 0R, 0Z)."""

    method: HomeMethod = Field(
        HomeMethod.SEARCH_1,
        strict=False,
        description="0: Low speed search 1; 0A: High speed search 2 (stops at once on ORG); "
        "0H: High speed search 1 (decelerates on ORG); 0R: search 2; 0Z: Z phase + ORG",
    )


class JogRequest(_Body):
    """Turn until stopped or a limit sensor turns on (§10 7, 8, H, L)."""

    direction: Direction = Field(strict=False, description="cw (positions count up) or ccw")
    speed: JogSpeed = Field(JogSpeed.LOW, strict=False, description="low (OL) or high (OH)")


class StepRequest(_Body):
    """One pulse (§10 7*, 8*)."""

    direction: Direction = Field(strict=False)


class StopRequest(_Body):
    """How to stop (§10 S, SS)."""

    mode: StopMode = Field(
        StopMode.DECELERATE,
        strict=False,
        description="decelerate (SS: to Low speed, then stop, no lost steps) or immediate (S)",
    )


class AckRequest(_Body):
    """Which latched errors the client has seen (all when left out)."""

    kinds: list[Annotated[ErrorKind, Strict(False)]] | None = Field(
        None, description="limit_error, emergency_stop, command_error"
    )
