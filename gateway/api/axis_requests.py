"""The request bodies of the axis routes (``extra="forbid"``: an unknown field is a 422)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from gateway.bus.state_types import ErrorKind
from gateway.service.axis_types import Direction, HomeMethod, JogSpeed, StopMode, Unit

__all__ = ["AckRequest", "HomeRequest", "JogRequest", "MoveRequest", "StepRequest", "StopRequest"]


class _Body(BaseModel):
    model_config = ConfigDict(extra="forbid")


class MoveRequest(_Body):
    """A move to a position, or by a distance."""

    position: float = Field(description="target (or distance when relative), in `unit`")
    relative: bool = Field(False, description="move by `position` from where the axis is")
    unit: Unit = Field(
        description="required, never assumed: `pulse` (controller pulses) or `user` (the "
        "axis's configured unit: mm, deg ...; see the axis's `unit`)"
    )


class HomeRequest(_Body):
    """An origin search (§10 0, 0A, 0H, 0R, 0Z)."""

    method: HomeMethod = Field(
        HomeMethod.SEARCH_1,
        description="0: Low speed search 1; 0A: High speed search 2 (stops at once on ORG); "
        "0H: High speed search 1 (decelerates on ORG); 0R: search 2; 0Z: Z phase + ORG",
    )


class JogRequest(_Body):
    """Turn until stopped or a limit sensor turns on (§10 7, 8, H, L)."""

    direction: Direction = Field(description="cw (positions count up) or ccw")
    speed: JogSpeed = Field(JogSpeed.LOW, description="low (OL) or high (OH)")


class StepRequest(_Body):
    """One pulse (§10 7*, 8*)."""

    direction: Direction


class StopRequest(_Body):
    """How to stop (§10 S, SS)."""

    mode: StopMode = Field(
        StopMode.DECELERATE,
        description="decelerate (SS: to Low speed, then stop, no lost steps) or immediate (S)",
    )


class AckRequest(_Body):
    """Which latched errors the client has seen (all when left out)."""

    kinds: list[ErrorKind] | None = Field(
        None, description="limit_error, emergency_stop, command_error"
    )
