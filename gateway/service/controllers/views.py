"""What the controller resources answer: reads answer with the resource (``PositionEntry``,
``IoView`` ...); writes answer with the transaction (``CommandResponse`` in ``replies``: the
typed reply, outcome and frames). Their request bodies are ``gateway.api.routes.bodies``.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

__all__ = [
    "BitView",
    "ContactName",
    "IoView",
    "ModeView",
    "PortView",
    "PositionEntry",
    "ProgramCheck",
    "ProgramData",
    "ProgramStatus",
    "ProgramText",
    "SensorLogicView",
]

#: a sensor input's logic: A contact (normally open) or B contact (normally closed) (§10 EA)
ContactName = Literal["A", "B"]


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


class ModeView(BaseModel):
    """The operating mode (§10 E): 0 pulse, 1 encoder, 2 servo."""

    controller: str
    mode: int


# ---------------------------------------------------------------------- programs


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
