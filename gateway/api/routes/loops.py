"""Routes of the loops: views, raw command text, the line trace.

``POST /loops/{loop}/raw`` (admin) takes command text for one controller of the loop and
parses it through the catalog first: text that fits no form is refused 422 with the reason
(the field and rule of the parser) and never reaches the wire.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Body, Path, Query, Request

from gateway.api.audit import audit_note
from gateway.api.problems import PROBLEM_RESPONSES
from gateway.api.routes.bodies import RawRequest, StopRequest, TraceSettings
from gateway.api.routes.deps import Admin, Operator, Service, Stops, Viewer, note_sent
from gateway.errors import NotFoundError
from gateway.service.controllers.command_results import CommandResponse
from gateway.service.controllers.service import TraceView
from gateway.service.stops import LoopStop
from gateway.service.views import LoopView

__all__ = ["router"]

router = APIRouter(tags=["loops"], responses=PROBLEM_RESPONSES)

Loop = Annotated[str, Path(description="the loop's name", examples=["sim"])]


@router.get("/loops", response_model=list[LoopView])
async def list_loops(service: Service, _: Viewer) -> list[LoopView]:
    """Every loop: link state, queue depth, counters, controllers."""
    return service.loops()


@router.get("/loops/{loop}", response_model=LoopView)
async def get_loop(loop: Loop, service: Service, _: Viewer) -> LoopView:
    """One loop."""
    return service.loop(loop)


@router.post("/loops/{loop}/stop", response_model=LoopStop)
async def stop_loop(
    loop: Loop,
    request: Request,
    stops: Stops,
    _: Operator,
    body: Annotated[StopRequest | None, Body()] = None,
) -> LoopStop:
    """Stop every axis of the loop: one stop per controller, all queued at stop priority at
    once. Never refused to an operator; each controller's outcome is reported (a controller
    that could not be reached is ``not_done``/``unknown`` with the reason, never left out)."""
    result = await stops.loop(loop, (body or StopRequest()).mode)
    frames = [frame for stop in result.stops for frame in stop.frames]
    audit_note(request, bytes_sent=frames, result=result.outcome.value)
    return result


@router.post("/loops/{loop}/raw", response_model=CommandResponse)
async def post_raw(
    loop: Loop, body: RawRequest, request: Request, service: Service, who: Admin
) -> CommandResponse:
    """Send command text (between body number and CR) to a controller of the loop, parsed
    through the catalog first; answered like ``/controllers/{id}/commands``, with the same
    soft-limit checks of motion commands (field ``text``)."""
    try:
        return note_sent(
            request,
            await service.raw(loop, body.controller, body.text, motor=body.motor, holder=who.name),
        )
    except NotFoundError as exc:
        if exc.kind == "controller":
            exc.field = "body.controller"
        raise


@router.get("/loops/{loop}/trace", response_model=TraceView)
async def get_trace(
    loop: Loop,
    service: Service,
    _: Admin,
    controller: Annotated[
        str | None, Query(max_length=64, description="only this controller")
    ] = None,
) -> TraceView:
    """The line trace of the loop (bounded; off until switched on with PUT)."""
    try:
        return service.trace(loop, controller)
    except NotFoundError as exc:
        if exc.kind == "controller":
            exc.field = "query.controller"
        raise


@router.put("/loops/{loop}/trace", response_model=TraceView)
async def put_trace(loop: Loop, body: TraceSettings, service: Service, _: Admin) -> TraceView:
    """Switch the line trace of the loop (whole loop, or some controllers)."""
    return service.set_trace(
        loop,
        enabled=body.enabled,
        controllers=body.controllers,
        hex_mode=body.hex,
        clear=body.clear,
    )
