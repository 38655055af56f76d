"""Routes of the controllers: views, any command, position table, I/O, sensor
logic, mode, EEPROM; the user-program routes are ``routes_programs`` (included here).

Paths are relative to ``/api/v1``. ``{id}`` is a controller id (``loop.body``) or its name.
Reads need the viewer role (the views) or the operator role (reads that use the line);
writes the operator role; mode and EEPROM the admin role. Every write puts the frames it sent
and its outcome into the audit entry.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

from fastapi import APIRouter, Body, Path, Query, Request

from gateway.api.audit import audit_note
from gateway.api.problems import PROBLEM_RESPONSES
from gateway.api.routes.bodies import (
    EepromRequest,
    ModeWrite,
    OutputBitWrite,
    OutputPulse,
    OutputsWrite,
    PositionWrite,
    SensorLogicWrite,
    StopRequest,
)
from gateway.api.routes.calls import AdminWrite, OperatorWrite
from gateway.api.routes.deps import (
    Id,
    Operator,
    Service,
    Stops,
    Viewer,
    forbid_unless,
    note_sent,
)
from gateway.api.routes.programs import router as programs_router
from gateway.protocol.command_text import Context, command_union
from gateway.protocol.models import Command
from gateway.service.commands import ROLE_RULE, required_role
from gateway.service.controllers.command_results import CommandResponse
from gateway.service.controllers.views import (
    BitView,
    IoView,
    ModeView,
    PositionEntry,
    SensorLogicView,
)
from gateway.service.stops import ControllerStop
from gateway.service.views import ControllerView

__all__ = ["router"]

if TYPE_CHECKING:
    HostCommand = Command
else:
    #: Any host command of the catalog: ``{"command": "OH{hs}", "hs": 4000}``.
    HostCommand = command_union(Context.HOST)

router = APIRouter(tags=["controllers"], responses=PROBLEM_RESPONSES)

Number = Annotated[int, Path(ge=0, le=999, description="position number 000-999 (§10 A)")]
Motor = Annotated[int, Path(ge=1, le=2, description="motor 1 or 2")]


# ---------------------------------------------------------------------- views


@router.get("/controllers", response_model=list[ControllerView])
async def list_controllers(service: Service, _: Viewer) -> list[ControllerView]:
    """Every controller as cached (no line traffic)."""
    return service.controllers()


@router.get("/controllers/{id}", response_model=ControllerView)
async def get_controller(
    id: Id,
    service: Service,
    _: Viewer,
    fresh: Annotated[bool, Query(description="read the status now (line traffic)")] = False,
) -> ControllerView:
    """One controller as cached, or read now with ``fresh=true`` (status, mode, selected
    motor, positions, program state)."""
    return await service.fresh_view(id) if fresh else service.view(id)


@router.post("/controllers/{id}/stop", response_model=ControllerStop)
async def stop_controller(
    id: Id,
    request: Request,
    stops: Stops,
    _: Operator,
    body: Annotated[StopRequest | None, Body()] = None,
) -> ControllerStop:
    """Stop both axes of the controller: one ``SS`` (decelerate) or ``S`` (immediate) at stop
    priority, acting on whichever motor moves. Never refused to an operator (no lease,
    motion or online check); the outcome says whether the controller took it."""
    result = await stops.controller(id, (body or StopRequest()).mode)
    audit_note(request, bytes_sent=result.frames, result=result.outcome.value)
    return result


# ---------------------------------------------------------------------- any command


@router.post(
    "/controllers/{id}/commands",
    response_model=CommandResponse,
    description="Send **any command of the catalog** as a typed body: the form's key in "
    '`command` and its parameters, e.g. `{"command": "OH{hs}", "hs": 4000}`; answered with '
    "its typed reply (decoded value, outcome, frames). Role: " + ROLE_RULE + ". Leases are "
    "checked for everything but queries and stops; a form the manual refuses while a motor "
    "moves or a program runs is 409, one not available in the controller's mode 422. `I` is "
    "refused (use PUT /controllers/{id}/program). On an axis with soft limits a motion "
    "command's target is resolved first (3: the 2D data, 4/5: position -/+ the data, "
    "B{pn}[+-]: the table entry) and checked (422 naming the rule), and the data checked is "
    "written again in the same transaction; a motion whose target cannot be known (7, 8, "
    "sequential B) is 422 there. A motion command answers when the controller accepted it; "
    "follow it with the axis views or use /axes for operations.",
)
async def post_command(
    id: Id,
    command: Annotated[HostCommand, Body()],
    request: Request,
    service: Service,
    principal: Operator,
    motor: Annotated[
        int | None,
        Query(
            ge=1,
            le=2,
            description="select this motor first (F) for a command without a motor digit",
        ),
    ] = None,
) -> CommandResponse:
    """Send one command of the catalog."""
    forbid_unless(principal, required_role(command), f"{command.wire()!r}")
    response = await service.command(id, command, holder=principal.name, motor=motor)
    return note_sent(request, response)


# ---------------------------------------------------------------------- position table


@router.get("/controllers/{id}/positions/{n}", response_model=PositionEntry)
async def get_position(id: Id, n: Number, service: Service, _: Operator) -> PositionEntry:
    """Entry n of the position table (``A{pn}D``)."""
    return await service.resources.position(service.controller(id), n)


@router.put("/controllers/{id}/positions/{n}", response_model=CommandResponse)
async def put_position(
    id: Id, n: Number, body: PositionWrite, write: OperatorWrite
) -> CommandResponse:
    """Set entry n: ``A{pn}{pp}``, or ``A{pn}`` (the current position) with ``current``."""
    ref = write.controller(id)
    response = await write.service.resources.set_position(
        ref, n, body.position, current=body.current, motor=body.motor, holder=write.holder
    )
    return write.noted(response)


# ---------------------------------------------------------------------- I/O


@router.get("/controllers/{id}/io", response_model=IoView)
async def get_io(id: Id, service: Service, _: Operator) -> IoView:
    """Inputs and outputs (``C``/``CO``; ``CA``/``COA`` in modes 0 and 1)."""
    return await service.resources.io(service.controller(id))


@router.get("/controllers/{id}/io/{port}/{bit}", response_model=BitView)
async def get_io_bit(
    id: Id,
    port: Literal["inputs", "outputs"],
    bit: Annotated[int, Path(ge=0, le=9, description="0-7 general; 8, 9 INP1/2 or CLR1/2")],
    service: Service,
    _: Operator,
) -> BitView:
    """One input bit (``C{bit}``) or output bit (``CO{bit}``)."""
    return await service.resources.bit(service.controller(id), port, bit)


@router.put("/controllers/{id}/io/outputs", response_model=CommandResponse)
async def put_outputs(id: Id, body: OutputsWrite, write: OperatorWrite) -> CommandResponse:
    """All general outputs (``D{du}{dl}``), with CLR1/CLR2 (``DA``, modes 0 and 1)."""
    ref = write.controller(id)
    clr = None if body.clr1 is None or body.clr2 is None else (body.clr1, body.clr2)
    response = await write.service.resources.set_outputs(ref, body.value, clr, holder=write.holder)
    return write.noted(response)


@router.put("/controllers/{id}/io/outputs/{bit}", response_model=CommandResponse)
async def put_output_bit(
    id: Id,
    bit: Annotated[int, Path(ge=0, le=9, description="0-7 general; 8 CLR1, 9 CLR2")],
    body: OutputBitWrite,
    write: OperatorWrite,
) -> CommandResponse:
    """One output bit ON or OFF (``D{bit}{value}B``)."""
    ref = write.controller(id)
    response = await write.service.resources.set_output_bit(ref, bit, body.on, holder=write.holder)
    return write.noted(response)


@router.post("/controllers/{id}/io/outputs/{bit}/pulse", response_model=CommandResponse)
async def pulse_output(
    id: Id,
    bit: Annotated[int, Path(ge=0, le=7)],
    body: OutputPulse,
    write: OperatorWrite,
) -> CommandResponse:
    """Output bit ON for ``time`` x 100 ms, then OFF (``P{bt}{time}``)."""
    ref = write.controller(id)
    response = await write.service.resources.pulse_output(ref, bit, body.time, holder=write.holder)
    return write.noted(response)


# ---------------------------------------------------------------------- sensor logic, mode


@router.get("/controllers/{id}/sensor-logic/{motor}", response_model=SensorLogicView)
async def get_sensor_logic(id: Id, motor: Motor, service: Service, _: Operator) -> SensorLogicView:
    """The sensor input logic of a motor (``EA``; not while moving)."""
    return await service.resources.sensor_logic(service.controller(id), motor)


@router.put("/controllers/{id}/sensor-logic/{motor}", response_model=CommandResponse)
async def put_sensor_logic(
    id: Id, motor: Motor, body: SensorLogicWrite, write: OperatorWrite
) -> CommandResponse:
    """Set the sensor input logic of a motor (``EA{du}{dl}``; the EMS bit is common)."""
    ref = write.controller(id)
    logic = body.logic()
    response = await write.service.resources.set_sensor_logic(
        ref, motor, logic, holder=write.holder
    )
    return write.noted(response)


@router.get("/controllers/{id}/mode", response_model=ModeView)
async def get_mode(id: Id, service: Service, _: Operator) -> ModeView:
    """The operating mode (read with ``94``)."""
    return await service.resources.mode(service.controller(id))


@router.put("/controllers/{id}/mode", response_model=CommandResponse)
async def put_mode(id: Id, body: ModeWrite, write: AdminWrite) -> CommandResponse:
    """Set the operating mode (``E{mode}``; admin; not while moving)."""
    ref = write.controller(id)
    return write.noted(await write.service.resources.set_mode(ref, body.mode, holder=write.holder))


# ---------------------------------------------------------------------- EEPROM


@router.post("/controllers/{id}/eeprom/save", response_model=CommandResponse)
async def eeprom_save(id: Id, body: EepromRequest, write: AdminWrite) -> CommandResponse:
    """Write RAM to the EEPROM: settings ``DW``, positions ``AW``, program ``IW``. The loop
    waits for the controller's ``$B#*`` before anything else is sent."""
    ref = write.controller(id)
    response = await write.service.resources.eeprom(ref, "save", body.area, holder=write.holder)
    return write.noted(response)


@router.post("/controllers/{id}/eeprom/load", response_model=CommandResponse)
async def eeprom_load(id: Id, body: EepromRequest, write: AdminWrite) -> CommandResponse:
    """Load the EEPROM into RAM: settings ``DL``, positions ``AL``, program ``IL``."""
    ref = write.controller(id)
    response = await write.service.resources.eeprom(ref, "load", body.area, holder=write.holder)
    return write.noted(response)


@router.post("/controllers/{id}/eeprom/erase", response_model=CommandResponse)
async def eeprom_erase(id: Id, write: AdminWrite) -> CommandResponse:
    """Erase everything written to the EEPROM (``EE///``: 10-20 s in which the controller
    answers nothing; the loop waits for its ``$B#*``)."""
    ref = write.controller(id)
    response = await write.service.resources.eeprom(ref, "erase", None, holder=write.holder)
    return write.noted(response)


router.include_router(programs_router)
