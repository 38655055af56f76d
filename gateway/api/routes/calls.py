"""The shapes routes share: what a motion route of an axis and a write to a controller are
called with besides their path and body, and the one way each answers.

A motion route takes ``Motion`` (or ``Homing``, whose default ``timeout`` is longer), starts
its operation on the axes and answers with ``MotionCall.answer``. A write to a controller
takes ``OperatorWrite`` or ``AdminWrite``, sends as the caller (its name holds the lease) and
answers with ``ControllerWrite.noted`` (the frames sent noted in the audit entry).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from fastapi import Depends, Query, Request, Response
from starlette.routing import NoMatchFound

from gateway.api.app_services import axes_of, controllers_of
from gateway.api.audit import audit_note
from gateway.api.motion_problems import motion_problem
from gateway.api.routes.deps import Admin, Operator, Service, note_sent
from gateway.api.security import Principal
from gateway.service.axes import AxisService
from gateway.service.controllers import ControllerService
from gateway.service.controllers.command_results import CommandResponse
from gateway.service.operations.book import Operation
from gateway.service.operations.types import OperationState, OperationView
from gateway.service.topology import ControllerRef

__all__ = [
    "AdminWrite",
    "Axes",
    "Call",
    "ControllerWrite",
    "Homing",
    "Motion",
    "MotionCall",
    "OperatorWrite",
    "axes_of",
    "controllers_of",
]

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


async def _axes(request: Request) -> AxisService:
    # async: a sync dependency costs every request a hop to the thread pool and back.
    return axes_of(request)


Axes = Annotated[AxisService, Depends(_axes)]


@dataclass(frozen=True)
class Call:
    """A route's HTTP request and its authenticated caller."""

    request: Request
    principal: Principal

    @property
    def holder(self) -> str:
        """The name the lease check and the audit know the caller by."""
        return self.principal.name


# ---------------------------------------------------------------------- axes: motion


@dataclass(frozen=True)
class MotionCall(Call):
    """What every motion route of an axis is called with besides its body: the HTTP
    request and response, the axes, the operator, ``wait`` and ``timeout``."""

    response: Response
    axes: AxisService
    wait: bool
    timeout: float

    async def answer(self, op: Operation, before: int | None) -> OperationView:
        """The answer to the operation ``op`` just started (the axis was at ``before``):
        202 + Location, or with ``wait`` the ended operation: 200 only when it is ``done``;
        ``failed`` and ``unknown`` are problems carrying the operation (``motion_problem``). A
        wait that times out is answered 202 with the operation still running: the device did
        nothing wrong, so no 5xx."""
        request, response = self.request, self.response
        try:
            location = str(request.app.url_path_for("get_operation", id=op.id))
        except NoMatchFound:
            location = f"/api/v1/operations/{op.id}"
        audit_note(request, bytes_sent=op.frames, operation=op.id, position_before=before)
        response.headers["Location"] = location
        if self.wait:
            op = await self.axes.operations.wait(op.id, self.timeout)
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


async def _motion(
    request: Request,
    response: Response,
    axes: Axes,
    principal: Operator,
    wait: Wait = False,
    timeout: Timeout = 30.0,
) -> MotionCall:
    return MotionCall(request, principal, response, axes, wait, timeout)


async def _homing(
    request: Request,
    response: Response,
    axes: Axes,
    principal: Operator,
    wait: Wait = False,
    timeout: Timeout = 60.0,  # a search may cross the whole travel at Low speed
) -> MotionCall:
    return MotionCall(request, principal, response, axes, wait, timeout)


Motion = Annotated[MotionCall, Depends(_motion)]
Homing = Annotated[MotionCall, Depends(_homing)]


# ---------------------------------------------------------------------- controllers: writes


@dataclass(frozen=True)
class ControllerWrite(Call):
    """A write's request, its caller and the controller service."""

    service: ControllerService

    def controller(self, ident: str) -> ControllerRef:
        """The controller ``ident`` (id or name); 404 naming it when there is none."""
        return self.service.controller(ident)

    def noted(self, response: CommandResponse) -> CommandResponse:
        """``response``, its frames and outcome noted in the request's audit entry."""
        return note_sent(self.request, response)


async def _operator_write(request: Request, service: Service, who: Operator) -> ControllerWrite:
    return ControllerWrite(request, who, service)


async def _admin_write(request: Request, service: Service, who: Admin) -> ControllerWrite:
    return ControllerWrite(request, who, service)


OperatorWrite = Annotated[ControllerWrite, Depends(_operator_write)]
AdminWrite = Annotated[ControllerWrite, Depends(_admin_write)]
