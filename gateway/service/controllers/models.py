"""Request and response models of the controller resources (issue 5, "Controller resources").

Reads answer with the resource (``PositionEntry``, ``IoView`` ...); writes answer with the
transaction (``CommandResponse``: the typed reply, outcome and frames). Request models forbid
unknown fields, so a misspelt field is a 422 naming it rather than silently ignored.
"""

from __future__ import annotations

from enum import StrEnum
from typing import Annotated, Literal, Self

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, model_validator

from gateway.protocol.params import exact_int

__all__ = [
    "Autostart",
    "BitView",
    "BufferWrite",
    "CounterWrite",
    "EepromArea",
    "EepromRequest",
    "IoView",
    "ModeView",
    "ModeWrite",
    "OutputBitWrite",
    "OutputPulse",
    "OutputsWrite",
    "PortView",
    "PositionEntry",
    "PositionWrite",
    "ProgramCheck",
    "ProgramData",
    "ProgramRun",
    "ProgramStatus",
    "ProgramStop",
    "ProgramText",
    "ProgramWrite",
    "RawRequest",
    "SensorLogicView",
    "SensorLogicWrite",
]

ContactName = Literal["A", "B"]
#: a motor number (1, 2): an integer, never ``true`` (which pydantic's Literal takes as 1)
MotorNumber = Annotated[Literal[1, 2], BeforeValidator(exact_int)]


class _Request(BaseModel):
    # Strict: JSON numbers and booleans only (no "5" for 5, no 1 for true); enum fields opt
    # out, as pydantic's strict mode would want enum members rather than their JSON strings.
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True)


class PortView(BaseModel):
    """Eight on/off bits: the byte, its hex digits DU DL, and the bits that are ON."""

    value: int = Field(ge=0, le=255)
    hex: str = Field(examples=["05"])
    on: list[int] = Field(description="bit numbers 0-7 that are ON")


# ---------------------------------------------------------------------- position table


class PositionEntry(BaseModel):
    """One entry of the 1000-point position table (§10 A), shared by both motors."""

    controller: str
    number: int = Field(ge=0, le=999)
    position: int = Field(description="pulses, as the controller reports them (§10 EP)")
    unit: Literal["pulse"] = Field("pulse", description="the unit of `position`")


class PositionWrite(_Request):
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


# ---------------------------------------------------------------------- I/O


class IoView(BaseModel):
    """The general I/O ports (§10 C, CO) and, in modes 0 and 1, INP and CLR as I/O (CA, COA)."""

    controller: str
    mode: int | None
    inputs: PortView
    outputs: PortView
    inp1: bool | None = Field(None, description="INP1 input (modes 0, 1; §10 C form III)")
    inp2: bool | None = None
    clr1: bool | None = Field(None, description="CLR1 output (modes 0, 1; §10 CO form II)")
    clr2: bool | None = None


class BitView(BaseModel):
    """One input or output bit."""

    controller: str
    bit: int
    on: bool


class OutputsWrite(_Request):
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


class OutputBitWrite(_Request):
    """One output bit ON or OFF (``D{bit}{value}B``; 8 = CLR1, 9 = CLR2 in modes 0, 1)."""

    on: bool


class OutputPulse(_Request):
    """Turn an output bit ON for ``time`` x 100 ms, then OFF (``P{bt}{time}``, §10 P)."""

    time: int = Field(ge=0, le=32767, description="units of 100 ms (0-32,767: about 54 min)")


# ---------------------------------------------------------------------- sensor logic, mode


class SensorLogicView(BaseModel):
    """The sensor input logic of one motor (§10 EA): A = normally open, B = normally closed."""

    controller: str
    motor: int
    step_out_sensor: ContactName
    limit: ContactName = Field(description="CW and CCW limit sensors together")
    org: ContactName
    emergency_stop: ContactName = Field(description="common to both motors (§10 EA)")
    inp: ContactName


class SensorLogicWrite(_Request):
    """The sensor input logic of one motor (``EA{du}{dl}``, not while moving)."""

    step_out_sensor: ContactName = "A"
    limit: ContactName = "A"
    org: ContactName = "A"
    emergency_stop: ContactName = "A"
    inp: ContactName = "A"


class ModeView(BaseModel):
    """The operating mode (§10 E): 0 pulse, 1 encoder, 2 servo."""

    controller: str
    mode: int


class ModeWrite(_Request):
    """Set the operating mode (``E{mode}``; admin; not while moving)."""

    mode: Annotated[Literal[0, 1, 2], BeforeValidator(exact_int)]


class EepromArea(StrEnum):
    """What an EEPROM save or load is about (§10 DW/DL, AW/AL, IW/IL)."""

    SETTINGS = "settings"  # DW / DL
    POSITIONS = "positions"  # AW / AL
    PROGRAM = "program"  # IW / IL


class EepromRequest(_Request):
    """Which EEPROM area to save or load."""

    area: EepromArea = Field(strict=False)


# ---------------------------------------------------------------------- programs


class ProgramWrite(_Request):
    """A user program's text (chapters 11-12), e.g. ``/D00/0//END``; validated first."""

    text: str = Field(min_length=1, max_length=20_000)


class ProgramCheck(BaseModel):
    """A program text that keeps every statically checkable rule of chapters 11-12."""

    steps: int = Field(description="statements as GN counts them")
    bytes: int = Field(description="JIS X 0201 bytes, as the capacity counts them (§10 I)")


class ProgramText(BaseModel):
    """The user program in the controller's RAM (``IR``)."""

    controller: str
    text: str
    bytes: int = Field(description="JIS X 0201 bytes, as the capacity counts them (§10 I)")
    steps: int | None = Field(description="statements as GN counts them; None: not parsable")


class ProgramRun(_Request):
    """Run the program from its start (``G``) or from a label (``G{lb}``)."""

    label: str | None = Field(None, description="one character; not A-Z or a-z (§10 G)")


class ProgramStop(_Request):
    """End the program: at the next statement boundary (``GE``), or at once stopping the
    motor too (``GES``, at stop priority)."""

    mode: Literal["end", "immediate"] = "end"


class ProgramStatus(BaseModel):
    """``GSS`` and ``GN``: the program's state and the next statement's step."""

    controller: str
    state: str = Field(description="1 running, 0 ended, P paused, E ended by an error")
    state_name: Literal["running", "ended", "paused", "error"]
    step: int = Field(description="the step of the next statement (GN)")


class ProgramData(BaseModel):
    """The program's data buffers A-F and counters 1, 2 (``GR``)."""

    controller: str
    buffers: dict[str, PortView]
    counters: dict[str, int]


class BufferWrite(_Request):
    """One data buffer byte (``GW{bf}{du}{dl}``)."""

    value: int = Field(ge=0, le=255)


class CounterWrite(_Request):
    """One counter (``GW{ct}{dt}``)."""

    value: int = Field(ge=0, le=65535)


class Autostart(BaseModel):
    """Program autostart at power-on (``GA``; ``GAS``/``GAR`` write the EEPROM at once)."""

    model_config = ConfigDict(extra="forbid", strict=True)

    enabled: bool


# ---------------------------------------------------------------------- raw


class RawRequest(_Request):
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
