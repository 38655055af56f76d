"""The words of axis requests: units, homing methods, directions, jog speeds, stop modes."""

from __future__ import annotations

from enum import StrEnum

from pydantic import BaseModel, Field

from gateway.bus.requests import Outcome

__all__ = ["Direction", "HomeMethod", "JogSpeed", "StopMode", "StopResult", "Unit"]


class Unit(StrEnum):
    """The unit of a position in a request."""

    PULSE = "pulse"
    USER = "user"


class HomeMethod(StrEnum):
    """Origin searches (§10 0, 0A, 0H, 0R, 0Z)."""

    SEARCH_1 = "0"  # Low speed, ORG sensor (machine origin search 1)
    HIGH_2 = "0A"  # High speed, stops at once on ORG (high-speed search 2)
    HIGH_1 = "0H"  # High speed, decelerates on ORG (high-speed search 1)
    SEARCH_2 = "0R"  # Low speed, RC-204A style (machine origin search 2)
    Z_PHASE = "0Z"  # encoder Z phase + ORG


class Direction(StrEnum):
    """Rotation direction: CW counts positions up (§10 4, 7), CCW down."""

    CW = "cw"
    CCW = "ccw"


class JogSpeed(StrEnum):
    """Jog speed: Low (OL) or High (OH) (§10 7, 8, H, L)."""

    LOW = "low"
    HIGH = "high"


class StopMode(StrEnum):
    """``immediate``: ``S`` stops at once (may lose steps at speed); ``decelerate``: ``SS``
    falls to Low speed first (§10 S, SS)."""

    IMMEDIATE = "immediate"
    DECELERATE = "decelerate"


class StopResult(BaseModel):
    """What a stop did."""

    axis: str
    command: str = Field(description="S or SS")
    outcome: Outcome
    frames: list[str]
    operation: str | None = Field(description="the operation the stop ended, if one was active")
