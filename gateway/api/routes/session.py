"""``GET /session``: who the caller is to the gateway, so a client can show its role.

A browser client (the dashboard) must know whether the gateway asks for a token at all
(the loopback demo runs without authentication) and which role a token has, to show only
the controls the role may use. Any valid token may ask about itself; nothing else is told.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, Request
from pydantic import BaseModel, Field

from gateway.api.problems import PROBLEM_RESPONSES
from gateway.api.security import AuthConfig, Principal, require
from gateway.service.roles import Role

__all__ = ["SessionView", "router"]

router = APIRouter(tags=["session"], responses=PROBLEM_RESPONSES)


class SessionView(BaseModel):
    """The caller as the gateway sees it."""

    name: str = Field(description="the token's name (anonymous without authentication)")
    role: Role
    authentication: bool = Field(description="False: the gateway runs without tokens")


@router.get("/session", response_model=SessionView)
async def get_session(
    request: Request, principal: Annotated[Principal, Depends(require(Role.VIEWER))]
) -> SessionView:
    """The caller's name and role, and whether the gateway asks for tokens at all."""
    auth = getattr(request.app.state, "auth", None)
    open_api = isinstance(auth, AuthConfig) and auth.no_auth
    return SessionView(name=principal.name, role=principal.role, authentication=not open_api)
