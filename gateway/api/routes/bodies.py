"""The request bodies of the HTTP API, in one place, on one strict base (``StrictBody``).

``extra="forbid"``: an unknown (misspelt) field is a 422 naming it rather than silently
ignored. ``strict=True``: a number is a JSON number and a boolean a JSON boolean, never
``"5"`` or ``true`` for a position. Enum fields opt out (``Field(strict=False)``): lax mode
takes their JSON strings (their values) and nothing else; strict mode would ask for Python enum
members. ``frozen=True``: a route reads a body, it never rewrites it. The service takes the
values these carry, never the bodies themselves.
"""

from __future__ import annotations

from typing import Annotated, Literal, Self

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, Strict, model_validator

from gateway.protocol.params import exact_int
from gateway.protocol.reply_values import Contact, SensorLogic
from gateway.protocol.speeds import OC_MAX, OS_MAX, OX_MAX, OX_MIN, SPEED_DATA_MAX
from gateway.service.control import ControlState
from gateway.service.controllers.resources import EepromArea
from gateway.service.controllers.views import ContactName
from gateway.service.leases import MAX_TTL
from gateway.service.operations.terms import Direction, HomeMethod, JogSpeed, StopMode, Unit
from gateway.service.runtime.bus_types import ErrorKind

__all__ = [
    "AckRequest",
    "Autostart",
    "BaudRequest",
    "BufferWrite",
    "ControlRequest",
    "CounterWrite",
    "EepromRequest",
    "HomeRequest",
    "JogRequest",
    "LeaseRequest",
    "ModeWrite",
    "MoveRequest",
    "OutputBitWrite",
    "OutputPulse",
    "OutputsWrite",
    "PositionWrite",
    "ProgramRun",
    "ProgramStop",
    "ProgramWrite",
    "RawRequest",
    "SensorLogicWrite",
    "SpeedChange",
    "StepRequest",
    "StopRequest",
    "StrictBody",
    "TraceSettings",
]

#: a motor number (1, 2): an integer, never ``true`` (which pydantic's Literal takes as 1)
MotorNumber = Annotated[Literal[1, 2], BeforeValidator(exact_int)]


class StrictBody(BaseModel):
    """What every request body of the API is: strict, closed, read-only (see the module)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


# ---------------------------------------------------------------------- axes


class MoveRequest(StrictBody):
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


class HomeRequest(StrictBody):
    """An origin search (§10 0, 0A, 0H, 0R, 0Z)."""

    method: HomeMethod = Field(
        HomeMethod.SEARCH_1,
        strict=False,
        description="0: Low speed search 1; 0A: High speed search 2 (stops at once on ORG); "
        "0H: High speed search 1 (decelerates on ORG); 0R: search 2; 0Z: Z phase + ORG",
    )


class JogRequest(StrictBody):
    """Turn until stopped or a limit sensor turns on (§10 7, 8, H, L)."""

    direction: Direction = Field(strict=False, description="cw (positions count up) or ccw")
    speed: JogSpeed = Field(JogSpeed.LOW, strict=False, description="low (OL) or high (OH)")


class StepRequest(StrictBody):
    """One pulse (§10 7*, 8*)."""

    direction: Direction = Field(strict=False)


class StopRequest(StrictBody):
    """How to stop (§10 S, SS)."""

    mode: StopMode = Field(
        StopMode.DECELERATE,
        strict=False,
        description="decelerate (SS: to Low speed, then stop, no lost steps) or immediate (S)",
    )


class AckRequest(StrictBody):
    """Which latched errors the client has seen (all when left out)."""

    kinds: list[Annotated[ErrorKind, Strict(False)]] | None = Field(
        None, description="limit_error, emergency_stop, command_error"
    )


class SpeedChange(StrictBody):
    """New speed data; the fields left out keep their value."""

    oh: int | None = Field(None, ge=1, le=SPEED_DATA_MAX, description="High speed data (§10 OH)")
    ol: int | None = Field(None, ge=1, le=SPEED_DATA_MAX, description="Low speed data (§10 OL)")
    os: int | None = Field(None, ge=1, le=OS_MAX, description="acceleration data (§10 OS)")
    oc: int | None = Field(None, ge=0, le=OC_MAX, description="S-curve rate % (§10 OC)")
    ox: int | None = Field(
        None, ge=OX_MIN, le=OX_MAX, description="frequency multiplier data (§10 OX), both motors"
    )


# ---------------------------------------------------------------------- leases, control


class LeaseRequest(StrictBody):
    """How long to hold the lease."""

    ttl: float = Field(
        60.0, gt=0, le=MAX_TTL, allow_inf_nan=False, description="seconds; renew before it ends"
    )


class ControlRequest(StrictBody):
    """Put a controller or a loop in local or remote control."""

    state: ControlState = Field(
        strict=False,  # the enum from its JSON string; anything else is still refused
        description="local: motion and settings from the network are refused (409), stops "
        "pass; remote: lifts this setting (a key switch or another setting may still hold)",
    )


# ---------------------------------------------------------------------- controllers


class PositionWrite(StrictBody):
    """Set an entry to ``position`` (``A{pn}{pp}``), or to the selected motor's current
    position with ``current: true`` (``A{pn}``, §10 A form II)."""

    position: int | None = Field(
        None, ge=-8_388_608, le=16_777_215, description="pulses (signed needs EP1 or mode 1)"
    )
    current: bool = Field(False, description="store the selected motor's current position")
    motor: MotorNumber | None = Field(
        None, description="with current: the motor whose position is stored (selected first)"
    )

    @model_validator(mode="after")
    def _one(self) -> Self:
        if (self.position is None) == (not self.current):
            raise ValueError("give either position or current: true")
        return self


class OutputsWrite(StrictBody):
    """All 8 general outputs at once (``D{du}{dl}``); with ``clr1`` and ``clr2`` also the CLR
    outputs as general outputs (``DA{dc}{du}{dl}``, modes 0 and 1 only, §10 D)."""

    value: int = Field(ge=0, le=255, description="bit 7..0 = output 7..0, 1 = ON")
    clr1: bool | None = None
    clr2: bool | None = None

    @model_validator(mode="after")
    def _both(self) -> Self:
        if (self.clr1 is None) != (self.clr2 is None):
            raise ValueError("give clr1 and clr2 together (DA sets both, §10 D form III)")
        return self


class OutputBitWrite(StrictBody):
    """One output bit ON or OFF (``D{bit}{value}B``; 8 = CLR1, 9 = CLR2 in modes 0, 1)."""

    on: bool


class OutputPulse(StrictBody):
    """Turn an output bit ON for ``time`` x 100 ms, then OFF (``P{bt}{time}``, §10 P)."""

    time: int = Field(ge=0, le=32767, description="units of 100 ms (0-32,767: about 54 min)")


class SensorLogicWrite(StrictBody):
    """The sensor input logic of one motor (``EA{du}{dl}``, not while moving)."""

    step_out_sensor: ContactName = "A"
    limit: ContactName = "A"
    org: ContactName = "A"
    emergency_stop: ContactName = "A"
    inp: ContactName = "A"

    def logic(self) -> SensorLogic:
        """The sensor logic these contacts make (its byte is ``EA``'s data)."""
        return SensorLogic(
            step_out_sensor=Contact[self.step_out_sensor],
            limit=Contact[self.limit],
            org=Contact[self.org],
            emergency_stop=Contact[self.emergency_stop],
            inp=Contact[self.inp],
        )


class ModeWrite(StrictBody):
    """Set the operating mode (``E{mode}``; admin; not while moving)."""

    mode: Annotated[Literal[0, 1, 2], BeforeValidator(exact_int)]


class EepromRequest(StrictBody):
    """Which EEPROM area to save or load."""

    area: EepromArea = Field(strict=False)


class ProgramWrite(StrictBody):
    """A user program's text (chapters 11-12), e.g. ``/D00/0//END``; validated first."""

    text: str = Field(min_length=1, max_length=20_000)


class ProgramRun(StrictBody):
    """Run the program from its start (``G``) or from a label (``G{lb}``)."""

    label: str | None = Field(None, description="one character; not A-Z or a-z (§10 G)")


class ProgramStop(StrictBody):
    """End the program: at the next statement boundary (``GE``), or at once stopping the
    motor too (``GES``, at stop priority)."""

    mode: Literal["end", "immediate"] = "end"


class BufferWrite(StrictBody):
    """One data buffer byte (``GW{bf}{du}{dl}``)."""

    value: int = Field(ge=0, le=255)


class CounterWrite(StrictBody):
    """One counter (``GW{ct}{dt}``)."""

    value: int = Field(ge=0, le=65535)


class Autostart(StrictBody):
    """Program autostart at power-on (``GA``; ``GAS``/``GAR`` write the EEPROM at once)."""

    enabled: bool


# ---------------------------------------------------------------------- loops


class RawRequest(StrictBody):
    """Command text for one controller of the loop, parsed through the catalog first."""

    controller: str = Field(
        max_length=64,
        description="the body number on this loop ('1'), or the controller's id or name",
        examples=["1"],
    )
    text: str = Field(
        min_length=0,
        max_length=5000,
        description="the text between body number and CR, e.g. OH4000",
        examples=["OH4000"],
    )
    motor: MotorNumber | None = Field(
        None, description="select this motor first (F) for commands without a motor digit"
    )


class TraceSettings(StrictBody):
    """Switch the line trace of a loop (whole loop, or some controllers)."""

    enabled: bool = Field(description="trace every controller of the loop")
    controllers: list[str] = Field(
        default_factory=list, description="body numbers or ids traced in addition"
    )
    hex: bool = False
    clear: bool = Field(False, description="forget the records kept so far")


class BaudRequest(StrictBody):
    """The loop's new rate."""

    baud: int = Field(description="9600, 1200 or 300 bps (§10 ES)", examples=[1200])
