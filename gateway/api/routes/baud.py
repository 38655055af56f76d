"""``POST /loops/{loop}/baud`` (admin): move every controller of a loop and the gateway's port
to another rate with ``ES`` (``gateway.service.baud``)."""

from __future__ import annotations

from fastapi import APIRouter, Request

from gateway.api.app_services import baud_of
from gateway.api.audit import audit_note
from gateway.api.problems import PROBLEM_RESPONSES
from gateway.api.routes.bodies import BaudRequest
from gateway.api.routes.deps import Admin
from gateway.api.routes.loops import Loop
from gateway.service.baud import BaudChange

__all__ = ["router"]

router = APIRouter(tags=["loops"], responses=PROBLEM_RESPONSES)


@router.post("/loops/{loop}/baud", response_model=BaudChange)
async def post_loop_baud(loop: Loop, body: BaudRequest, request: Request, _: Admin) -> BaudChange:
    """Move every controller of the loop to ``baud`` (``ES``, written to their EEPROM), reopen
    the port at it and read each controller there; when one does not answer, the others go
    back to the old rate. 200 with each controller's result (``outcome`` done, rolled_back or
    failed). Change ``loops[].baud`` in the configuration file afterwards."""
    result = await baud_of(request).change(loop, body.baud)
    frames = [f for c in result.controllers for f in c.frames]
    audit_note(request, bytes_sent=frames, result=result.outcome)
    return result
