"""Routes of local and remote control (``gateway.service.control``): admin only.

``PUT /controllers/{id}/control`` and ``PUT /loops/{loop}/control`` with ``{"state": "local"}``
or ``{"state": "remote"}``. ``remote`` lifts the setting made at that level only: a
controller an admin set local stays local when its loop goes remote, and a key switch keeps
its controller local whatever the API says (the answer shows what still holds it). Each
change is in the request's audit entry and on the WebSocket (``control`` event, and the
controller's and axes' views).
"""

from __future__ import annotations

from fastapi import APIRouter, Request
from pydantic import BaseModel, Field

from gateway.api.audit import audit_note
from gateway.api.problems import PROBLEM_RESPONSES
from gateway.api.routes.bodies import ControlRequest
from gateway.api.routes.deps import Admin, Id, Service
from gateway.api.routes.loops import Loop
from gateway.service.control import ControlSourceView, ControlView

__all__ = ["LoopControlView", "router"]

router = APIRouter(tags=["control"], responses=PROBLEM_RESPONSES)


class ControllerControlView(ControlView):
    """A controller's control state after the change."""

    controller: str = Field(examples=["sim.1"])


class LoopControlView(BaseModel):
    """A loop's control setting and each controller's state after the change."""

    loop: str
    local: ControlSourceView | None = Field(description="the loop-wide setting, if any")
    controllers: list[ControllerControlView]


@router.put("/controllers/{id}/control", response_model=ControllerControlView)
async def put_controller_control(
    id: Id, body: ControlRequest, request: Request, service: Service, who: Admin
) -> ControllerControlView:
    """Set one controller local or remote (admin). Never sends anything to the line."""
    ref = service.controller(id)
    view = service.runtime.control.set_controller(ref, body.state, who.name)
    audit_note(request, result=view.state.value, control=view.model_dump(mode="json"))
    return ControllerControlView(controller=ref.id, **view.model_dump())


@router.put("/loops/{loop}/control", response_model=LoopControlView)
async def put_loop_control(
    loop: Loop, body: ControlRequest, request: Request, service: Service, who: Admin
) -> LoopControlView:
    """Set every controller of a loop local, or lift the loop's setting (admin)."""
    ref = service.runtime.topology.loop(loop)
    control = service.runtime.control
    views = control.set_loop(ref.name, body.state, who.name)
    answer = LoopControlView(
        loop=ref.name,
        local=control.loop_local(ref.name),
        controllers=[
            ControllerControlView(controller=c.id, **v.model_dump())
            for c, v in zip(ref.controllers, views, strict=True)
        ],
    )
    audit_note(request, result=body.state.value, control=answer.model_dump(mode="json"))
    return answer
