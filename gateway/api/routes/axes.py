"""Routes of the axes: views, motion, stop, speed, errors, and the control leases.

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

from fastapi import APIRouter, Body, Path, Query, Request

from gateway.api.audit import audit_note
from gateway.api.motion_problems import MOTION_PROBLEM_RESPONSES
from gateway.api.problems import PROBLEM_RESPONSES
from gateway.api.routes.bodies import (
    AckRequest,
    HomeRequest,
    JogRequest,
    LeaseRequest,
    MoveRequest,
    SpeedChange,
    StepRequest,
    StopRequest,
)
from gateway.api.routes.calls import Axes, Homing, Motion, axes_of, controllers_of
from gateway.api.routes.deps import Operator, Viewer
from gateway.api.routes.leases import LeaseView, lease_routes
from gateway.service.axes.service import (
    StopResult,
)
from gateway.service.axes.speeds import SpeedView
from gateway.service.operations.types import OperationView
from gateway.service.views import AxisView

__all__ = ["router"]

router = APIRouter(tags=["axes"], responses=PROBLEM_RESPONSES)

Id = Annotated[str, Path(description="axis id (loop.body.motor) or name", examples=["sim.1.1"])]


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
async def move(id: Id, body: MoveRequest, motion: Motion) -> OperationView:
    """Move to ``position`` (``relative``: by it); soft limits and the position counter are
    checked before anything is sent. Absolute: ``2{pp}`` + ``3``; relative ``2{|d|}`` +
    ``4`` (CW) / ``5`` (CCW) (§10 2, 3, 4, 5)."""
    before = motion.axes.position(id)
    op = await motion.axes.move(
        id, body.position, relative=body.relative, unit=body.unit, holder=motion.holder
    )
    return await motion.answer(op, before)


@router.post("/axes/{id}/home", **_MOTION)  # type: ignore[arg-type]
async def home(
    id: Id, motion: Homing, body: Annotated[HomeRequest | None, Body()] = None
) -> OperationView:
    """Search the origin; the position is 0 where it ends (§10 0, 0A, 0H, 0R, 0Z)."""
    before = motion.axes.position(id)
    method = (body or HomeRequest()).method
    op = await motion.axes.home(id, method, holder=motion.holder)
    return await motion.answer(op, before)


@router.post("/axes/{id}/jog", **_MOTION)  # type: ignore[arg-type]
async def jog(id: Id, body: JogRequest, motion: Motion) -> OperationView:
    """Turn at Low (``7``/``8``) or High speed (then ``H``) until a stop or a limit; the
    same request on a jog already running changes only its speed (``H``/``L``). Toward a
    soft limit the jog is a move to the limit at the jog speed (``2`` + ``3``; Low: OH set
    to OL for it), ended by a stop like any jog; at or past the limit: 422."""
    before = motion.axes.position(id)
    op = await motion.axes.jog(id, body.direction, body.speed, holder=motion.holder)
    return await motion.answer(op, before)


@router.post("/axes/{id}/step", **_MOTION)  # type: ignore[arg-type]
async def step(id: Id, body: StepRequest, motion: Motion) -> OperationView:
    """One pulse CW (``7*``) or CCW (``8*``), inside the soft limits."""
    before = motion.axes.position(id)
    op = await motion.axes.step(id, body.direction, holder=motion.holder)
    return await motion.answer(op, before)


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
    view = await axes.set_speed(id, body.model_dump(exclude_none=True), holder=principal.name)
    audit_note(request, bytes_sent=view.frames, result=view.model_dump(mode="json"))
    return view


@router.post("/axes/{id}/errors/ack", response_model=AxisView)
async def acknowledge(
    id: Id, axes: Axes, _: Operator, body: Annotated[AckRequest | None, Body()] = None
) -> AxisView:
    """The client has seen the latched errors of the axis: they stop showing (no traffic)."""
    return axes.acknowledge(id, (body or AckRequest()).kinds)


# ---------------------------------------------------------------------- leases

lease_routes(router, "axes", "axis", lambda request, ident: axes_of(request).ref(ident).id)
lease_routes(
    router,
    "controllers",
    "controller",
    lambda request, ident: controllers_of(request).controller(ident).id,
)

__all__ += ["LeaseRequest", "LeaseView"]
