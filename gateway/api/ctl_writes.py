"""The one shape of a route that writes to a controller: resolve the controller, send as the
caller (its name holds the lease), and note the frames sent in the audit entry.

``OperatorWrite`` / ``AdminWrite`` are what such a route takes besides its path and body.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated

from fastapi import Depends, Request

from gateway.api.ctl_deps import Admin, Operator, Service, note_sent
from gateway.api.security import Principal
from gateway.service.controllers import ControllerService
from gateway.service.controllers.replies import CommandResponse
from gateway.service.topology import ControllerRef

__all__ = ["AdminWrite", "ControllerWrite", "OperatorWrite"]


@dataclass(frozen=True)
class ControllerWrite:
    """A write's request, the controller service and the caller."""

    request: Request
    service: ControllerService
    principal: Principal

    @property
    def holder(self) -> str:
        """The name the lease check and the audit know the caller by."""
        return self.principal.name

    def controller(self, ident: str) -> ControllerRef:
        """The controller ``ident`` (id or name); 404 naming it when there is none."""
        return self.service.controller(ident)

    def noted(self, response: CommandResponse) -> CommandResponse:
        """``response``, its frames and outcome noted in the request's audit entry."""
        return note_sent(self.request, response)


async def _operator_write(request: Request, service: Service, who: Operator) -> ControllerWrite:
    return ControllerWrite(request, service, who)


async def _admin_write(request: Request, service: Service, who: Admin) -> ControllerWrite:
    return ControllerWrite(request, service, who)


OperatorWrite = Annotated[ControllerWrite, Depends(_operator_write)]
AdminWrite = Annotated[ControllerWrite, Depends(_admin_write)]
