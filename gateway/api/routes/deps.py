"""The routes' dependencies in one place: the roles a route needs, the services the app holds,
the controller path type, and the audit note of what was sent.

``controllers(request)`` is the ``ControllerService`` the app holds and ``stops(request)`` its
stop-all, both through the app's one getter of each service (``gateway.api.app_services``).
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Path, Request

from gateway.api.app_services import controllers_of, stops_of
from gateway.api.audit import audit_note
from gateway.api.problems import ApiProblem, Problem, problem_type
from gateway.api.security import Principal, require
from gateway.service.commands import ROLE_RULE
from gateway.service.controllers.command_results import CommandResponse
from gateway.service.controllers.service import ControllerService
from gateway.service.roles import Role
from gateway.service.stops import StopAll

__all__ = [
    "Admin",
    "Id",
    "Operator",
    "Service",
    "Stops",
    "Viewer",
    "controllers",
    "forbid_unless",
    "note_sent",
]

Id = Annotated[str, Path(description="controller id (loop.body) or name", examples=["sim.1"])]
Viewer = Annotated[Principal, Depends(require(Role.VIEWER))]
Operator = Annotated[Principal, Depends(require(Role.OPERATOR))]
Admin = Annotated[Principal, Depends(require(Role.ADMIN))]


async def controllers(request: Request) -> ControllerService:
    """The controller service of the app."""
    return controllers_of(request)


Service = Annotated[ControllerService, Depends(controllers)]


async def stops(request: Request) -> StopAll:
    """The stop-all of the app (controllers and loops)."""
    return stops_of(request)


Stops = Annotated[StopAll, Depends(stops)]


def note_sent(request: Request, response: CommandResponse) -> CommandResponse:
    """Record what went out in the audit entry of ``request``; ``response`` unchanged."""
    audit_note(request, bytes_sent=response.frames, result=response.outcome)
    return response


def forbid_unless(principal: Principal, needed: Role, what: str) -> None:
    """403 when ``principal`` lacks ``needed`` (a rule that depends on the request body)."""
    if principal.role.allows(needed):
        return
    raise ApiProblem(
        Problem(
            type=problem_type("forbidden"),
            title="Forbidden",
            status=403,
            detail=f"{what} needs the {needed} role; the token {principal.name!r} has the "
            f"{principal.role} role ({ROLE_RULE})",
            required_role=str(needed),
        )
    )
