"""Routes of a controller's user program: upload, read back, run, pause, resume,
stop, status, buffers and counters, autostart (§10 G ... IW).

Upload and autostart need the admin role; running, pausing, resuming, stopping and writing
buffers or counters the operator role; reading the program or its state the operator role too
(they use the line). Included by ``routes_controllers``.
"""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, Path

from gateway.api.problems import PROBLEM_RESPONSES
from gateway.api.routes.bodies import (
    Autostart,
    BufferWrite,
    CounterWrite,
    ProgramRun,
    ProgramStop,
    ProgramWrite,
)
from gateway.api.routes.calls import AdminWrite, OperatorWrite
from gateway.api.routes.deps import Id, Operator, Service
from gateway.service.controllers.command_results import CommandResponse
from gateway.service.controllers.views import (
    ProgramCheck,
    ProgramData,
    ProgramStatus,
    ProgramText,
)

__all__ = ["router"]

router = APIRouter(tags=["programs"], responses=PROBLEM_RESPONSES)

Buffer = Annotated[Literal["A", "B", "C", "D", "E", "F"], Path(description="data buffer A-F")]
Counter = Annotated[int, Path(ge=1, le=2, description="counter 1 or 2")]


@router.put("/controllers/{id}/program", response_model=CommandResponse)
async def put_program(id: Id, body: ProgramWrite, write: AdminWrite) -> CommandResponse:
    """Validate the program text (chapters 11-12: a broken rule is 422 naming the step, the
    field and the rule; nothing is sent) and upload it (``I``, the text, CR)."""
    ref = write.controller(id)
    response = await write.service.programs.upload(ref, body.text, holder=write.holder)
    return write.noted(response)


@router.get("/controllers/{id}/program", response_model=ProgramText)
async def get_program(id: Id, service: Service, _: Operator) -> ProgramText:
    """The program in the controller's RAM, read back with ``IR``."""
    return await service.programs.text(service.controller(id))


@router.post("/controllers/{id}/program/run", response_model=CommandResponse)
async def run_program(
    id: Id, write: OperatorWrite, body: ProgramRun | None = None
) -> CommandResponse:
    """Run the program from its start (``G``) or from a label (``G{lb}``)."""
    ref = write.controller(id)
    label = body.label if body is not None else None
    return write.noted(await write.service.programs.run(ref, label, holder=write.holder))


@router.post("/controllers/{id}/program/pause", response_model=CommandResponse)
async def pause_program(id: Id, write: OperatorWrite) -> CommandResponse:
    """Pause the running program (``GS``)."""
    ref = write.controller(id)
    return write.noted(await write.service.programs.pause(ref, holder=write.holder))


@router.post("/controllers/{id}/program/resume", response_model=CommandResponse)
async def resume_program(id: Id, write: OperatorWrite) -> CommandResponse:
    """Resume a paused program (``GC``)."""
    ref = write.controller(id)
    return write.noted(await write.service.programs.resume(ref, holder=write.holder))


@router.post("/controllers/{id}/program/stop", response_model=CommandResponse)
async def stop_program(
    id: Id, write: OperatorWrite, body: ProgramStop | None = None
) -> CommandResponse:
    """End the program: ``GE`` (mode end), or ``GES`` (mode immediate: the motor stops too,
    sent at stop priority). Never refused by a lease."""
    ref = write.controller(id)
    mode = body.mode if body is not None else "end"
    return write.noted(await write.service.programs.stop(ref, mode, holder=write.holder))


@router.get("/controllers/{id}/program/status", response_model=ProgramStatus)
async def program_status(id: Id, service: Service, _: Operator) -> ProgramStatus:
    """The program's state (``GSS``) and next step (``GN``)."""
    return await service.programs.status(service.controller(id))


@router.get("/controllers/{id}/program/data", response_model=ProgramData)
async def program_data(id: Id, service: Service, _: Operator) -> ProgramData:
    """Data buffers A-F and counters 1, 2 (``GR``)."""
    return await service.programs.data(service.controller(id))


@router.put("/controllers/{id}/program/buffers/{buffer}", response_model=CommandResponse)
async def put_buffer(
    id: Id, buffer: Buffer, body: BufferWrite, write: OperatorWrite
) -> CommandResponse:
    """Write one data buffer byte (``GW{bf}{du}{dl}``)."""
    ref = write.controller(id)
    response = await write.service.programs.set_buffer(ref, buffer, body.value, holder=write.holder)
    return write.noted(response)


@router.put("/controllers/{id}/program/counters/{counter}", response_model=CommandResponse)
async def put_counter(
    id: Id, counter: Counter, body: CounterWrite, write: OperatorWrite
) -> CommandResponse:
    """Write one counter (``GW{ct}{dt}``)."""
    ref = write.controller(id)
    response = await write.service.programs.set_counter(
        ref, counter, body.value, holder=write.holder
    )
    return write.noted(response)


@router.get("/controllers/{id}/program/autostart", response_model=Autostart)
async def get_autostart(id: Id, service: Service, _: Operator) -> Autostart:
    """Whether the program starts at power-on (``GA``)."""
    return Autostart(enabled=await service.programs.autostart(service.controller(id)))


@router.put("/controllers/{id}/program/autostart", response_model=CommandResponse)
async def put_autostart(id: Id, body: Autostart, write: AdminWrite) -> CommandResponse:
    """Switch autostart (``GAS``/``GAR``, written to the EEPROM at once; admin)."""
    ref = write.controller(id)
    response = await write.service.programs.set_autostart(ref, body.enabled, holder=write.holder)
    return write.noted(response)


@router.post("/programs/check", response_model=ProgramCheck)
async def check_program(body: ProgramWrite, service: Service, _: Operator) -> ProgramCheck:
    """Check a program text against the rules of chapters 11-12 without sending anything:
    200 with its size, or 422 naming the step, the field and the rule (what an upload with
    ``PUT /controllers/{id}/program`` would answer). For editors that check as you type."""
    program = service.programs.check(body.text)
    return ProgramCheck(steps=program.step_count, bytes=program.size_bytes)
