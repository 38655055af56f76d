"""Routes of the axes (issue 5): views, motion, stop, speed, errors, and the control leases.

Paths are relative to ``/api/v1``; ``{id}`` is an axis id (``loop.body.motor``) or its name.
Reads are for viewers; motion, settings and leases for operators. Motion answers ``202`` with
the operation (``Location: /api/v1/operations/{id}``) once the controller has taken the
command, or with ``?wait=true`` the operation once ended: ``200`` only when it is ``done``;
``failed`` answers 409 and ``unknown`` 504, as problems that carry the operation
(``gateway.api.motion_problems``); when ``timeout`` passes first, ``202`` with the operation
as it is then: the motion goes on, nothing failed. A stop is never refused, not even by a
lease or a motion.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Body, Depends, Path, Query, Request, Response
from starlette.routing import NoMatchFound

from gateway.api.audit import audit_note
from gateway.api.axis_requests import (
    AckRequest,
    HomeRequest,
    JogRequest,
    MoveRequest,
    StepRequest,
    StopRequest,
)
from gateway.api.motion_problems import MOTION_PROBLEM_RESPONSES, motion_problem
from gateway.api.problems import PROBLEM_RESPONSES
from gateway.api.routes_leases import LeaseRequest, LeaseView, lease_routes
from gateway.api.security import Principal, require
from gateway.service.axes import (
    AxisService,
    StopResult,
)
from gateway.service.axis_speeds import SpeedChange, SpeedView
from gateway.service.operation_types import OperationState, OperationView
from gateway.service.operations import Operation, Operations
from gateway.service.roles import Role
from gateway.service.views import AxisView

__all__ = ["router"]

router = APIRouter(tags=["axes"], responses=PROBLEM_RESPONSES)

Id = Annotated[str, Path(description="axis id (loop.body.motor) or name", examples=["sim.1.1"])]
Viewer = Annotated[Principal, Depends(require(Role.VIEWER))]
Operator = Annotated[Principal, Depends(require(Role.OPERATOR))]
Wait = Annotated[bool, Query(description="answer when the motion has ended")]
Timeout = Annotated[
    float,
    Query(
        gt=0,
        le=3600,
        allow_inf_nan=False,
        description="seconds to wait with wait=true (then 202: still running)",
    ),
]


def _axes_of(request: Request) -> AxisService:
    service: AxisService = request.app.state.axes
    return service


async def _axes(request: Request) -> AxisService:
    # async: a sync dependency costs every request a hop to the thread pool and back.
    return _axes_of(request)


async def _operations(request: Request) -> Operations:
    service: Operations = request.app.state.operations
    return service


Axes = Annotated[AxisService, Depends(_axes)]


# ---------------------------------------------------------------------- views


@router.get("/axes", response_model=list[AxisView])
async def list_axes(axes: Axes, _: Viewer) -> list[AxisView]:
    """Every axis as cached (no line traffic)."""
    return axes.views()


@router.get("/axes/{id}", response_model=AxisView)
async def get_axis(
    id: Id,
    axes: Axes,
    _: Viewer,
    fresh: Annotated[bool, Query(description="read status and position now")] = False,
) -> AxisView:
    """One axis as cached, or read now with ``fresh=true``."""
    return await axes.fresh(id) if fresh else axes.view(id)


# ---------------------------------------------------------------------- motion


async def _answer(
    request: Request,
    response: Response,
    operations: Operations,
    op: Operation,
    before: int | None,
    wait: bool,
    timeout: float,
) -> OperationView:
    """202 + Location, or with ``wait`` the ended operation: 200 only when it is ``done``;
    ``failed`` and ``unknown`` are problems carrying the operation (``motion_problem``). A
    wait that times out is answered 202 with the operation still running: the device did
    nothing wrong, so no 5xx."""
    try:
        location = str(request.app.url_path_for("get_operation", id=op.id))
    except NoMatchFound:
        location = f"/api/v1/operations/{op.id}"
    audit_note(request, bytes_sent=op.frames, operation=op.id, position_before=before)
    response.headers["Location"] = location
    if wait:
        op = await operations.wait(op.id, timeout)
        if op.final:
            audit_note(request, position_after=op.position, result=op.state.value)
            if op.state is not OperationState.DONE:
                raise motion_problem(op.view(), location)
            response.status_code = 200
        else:
            audit_note(request, result=op.state.value)
            response.status_code = 202
    else:
        response.status_code = 202
        audit_note(request, result=op.state.value)
    return op.view()


_MOTION = {
    "status_code": 202,
    "response_model": OperationView,
    "responses": {
        200: {"model": OperationView, "description": "with wait=true: the motion is done"},
        202: {"description": "the command is taken (with wait=true: still running at timeout)"},
        **MOTION_PROBLEM_RESPONSES,
    },
}


@router.post("/axes/{id}/move", **_MOTION)  # type: ignore[arg-type]
async def move(
    id: Id,
    body: MoveRequest,
    request: Request,
    response: Response,
    axes: Axes,
    principal: Annotated[Principal, Depends(require(Role.OPERATOR))],
    wait: Wait = False,
    timeout: Timeout = 30.0,
) -> OperationView:
    """Move to ``position`` (``relative``: by it); soft limits and the position counter are
    checked before anything is sent. Absolute: ``2{pp}`` + ``3``; relative ``2{|d|}`` +
    ``4`` (CW) / ``5`` (CCW) (§10 2, 3, 4, 5)."""
    before = axes.position(id)
    op = await axes.move(
        id, body.position, relative=body.relative, unit=body.unit, holder=principal.name
    )
    return await _answer(request, response, axes.operations, op, before, wait, timeout)


@router.post("/axes/{id}/home", **_MOTION)  # type: ignore[arg-type]
async def home(
    id: Id,
    request: Request,
    response: Response,
    axes: Axes,
    principal: Annotated[Principal, Depends(require(Role.OPERATOR))],
    body: Annotated[HomeRequest | None, Body()] = None,
    wait: Wait = False,
    timeout: Timeout = 60.0,
) -> OperationView:
    """Search the origin; the position is 0 where it ends (§10 0, 0A, 0H, 0R, 0Z)."""
    before = axes.position(id)
    method = (body or HomeRequest()).method
    op = await axes.home(id, method, holder=principal.name)
    return await _answer(request, response, axes.operations, op, before, wait, timeout)


@router.post("/axes/{id}/jog", **_MOTION)  # type: ignore[arg-type]
async def jog(
    id: Id,
    body: JogRequest,
    request: Request,
    response: Response,
    axes: Axes,
    principal: Annotated[Principal, Depends(require(Role.OPERATOR))],
    wait: Wait = False,
    timeout: Timeout = 30.0,
) -> OperationView:
    """Turn at Low (``7``/``8``) or High speed (then ``H``) until a stop or a limit; the
    same request on a jog already running changes only its speed (``H``/``L``). Toward a
    soft limit the jog is a move to the limit at the jog speed (``2`` + ``3``; Low: OH set
    to OL for it), ended by a stop like any jog; at or past the limit: 422."""
    before = axes.position(id)
    op = await axes.jog(id, body.direction, body.speed, holder=principal.name)
    return await _answer(request, response, axes.operations, op, before, wait, timeout)


@router.post("/axes/{id}/step", **_MOTION)  # type: ignore[arg-type]
async def step(
    id: Id,
    body: StepRequest,
    request: Request,
    response: Response,
    axes: Axes,
    principal: Annotated[Principal, Depends(require(Role.OPERATOR))],
    wait: Wait = False,
    timeout: Timeout = 30.0,
) -> OperationView:
    """One pulse CW (``7*``) or CCW (``8*``), inside the soft limits."""
    before = axes.position(id)
    op = await axes.step(id, body.direction, holder=principal.name)
    return await _answer(request, response, axes.operations, op, before, wait, timeout)


@router.post("/axes/{id}/stop", response_model=StopResult)
async def stop(
    id: Id,
    request: Request,
    axes: Axes,
    _: Operator,
    body: Annotated[StopRequest | None, Body()] = None,
) -> StopResult:
    """Stop now: ``SS`` (decelerate) or ``S`` (immediate), at stop priority. Never refused:
    no lease or motion check."""
    before = axes.position(id)
    result = await axes.stop(id, (body or StopRequest()).mode)
    audit_note(
        request,
        bytes_sent=result.frames,
        result=result.outcome.value,
        operation=result.operation,
        position_before=before,
    )
    return result


# ---------------------------------------------------------------------- speed and errors


@router.get("/axes/{id}/speed", response_model=SpeedView)
async def get_speed(id: Id, axes: Axes, _: Operator) -> SpeedView:
    """Read OH, OL, OS, OC and the shared OX now, with fH, fL, α, tacc and ts (§7-1).
    Uses the line, hence the operator role."""
    return await axes.speed(id)


@router.put("/axes/{id}/speed", response_model=SpeedView)
async def put_speed(
    id: Id, body: SpeedChange, request: Request, axes: Axes, principal: Operator
) -> SpeedView:
    """Set speed data (left-out fields keep their value) and read them back. Refused before
    sending: ranges, and the S-curve rule (OH - OL) / (2 x (200 - OC)) x OC <= 4,095,
    <= 16,383 - OH, <= 16,383 - OL (§7-1). OX is shared by both motors."""
    view = await axes.set_speed(id, body, holder=principal.name)
    audit_note(request, bytes_sent=view.frames, result=view.model_dump(mode="json"))
    return view


@router.post("/axes/{id}/errors/ack", response_model=AxisView)
async def acknowledge(
    id: Id, axes: Axes, _: Operator, body: Annotated[AckRequest | None, Body()] = None
) -> AxisView:
    """The client has seen the latched errors of the axis: they stop showing (no traffic)."""
    return axes.acknowledge(id, (body or AckRequest()).kinds)


# ---------------------------------------------------------------------- leases

lease_routes(router, "axes", "axis", lambda request, ident: _axes_of(request).ref(ident).id)
lease_routes(
    router,
    "controllers",
    "controller",
    lambda request, ident: _axes_of(request).gateway.topology.controller(ident).id,
)

__all__ += ["LeaseRequest", "LeaseView"]
