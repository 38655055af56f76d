"""Who an OPC UA session is: a token of the configuration's book, or anonymous.

A user logs in with the token's name as user name and the token itself as password: the same
book and roles as the REST API, so a viewer's token browses and reads but calls no method.
Anonymous sessions exist only when the configuration allows them, and are viewers.

asyncua hands a method only the object it is called on, not the session: ``SessionUsers``
wraps the session's ``call`` so that the session's user is in a context variable while its
methods run (each call is awaited within the request's task, so the variable is the caller's).
"""

from __future__ import annotations

import contextvars
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from asyncua.crypto.permission_rules import User, UserRole
from asyncua.server.internal_session import InternalSession

from gateway.service.principal import Identify
from gateway.service.roles import Role

__all__ = ["ANONYMOUS", "CLIENT", "GatewayUser", "TokenUsers", "caller", "install_caller_context"]

#: The name anonymous sessions are audited under.
ANONYMOUS = "anonymous"
#: The client an OPC UA session's principal names.
CLIENT = "opcua"


@dataclass
class GatewayUser(User):
    """An asyncua user with the gateway's role (asyncua's own role lets it read and call)."""

    gateway_role: Role = Role.VIEWER


class TokenUsers:
    """asyncua's user manager over the gateway's token book."""

    def __init__(self, identify: Identify, *, anonymous: bool) -> None:
        self.identify, self.anonymous = identify, anonymous

    def get_user(
        self,
        iserver: Any,
        username: str | None = None,
        password: str | None = None,
        certificate: Any = None,
    ) -> User | None:
        """The session's user; None refuses the session (``Bad_UserAccessDenied``)."""
        if username is None and password is None:
            if not self.anonymous:
                return None
            return GatewayUser(role=UserRole.User, name=ANONYMOUS, gateway_role=Role.VIEWER)
        token = password if isinstance(password, str) else None
        principal = self.identify(token, CLIENT) if token else None
        if principal is None or principal.name != username:
            return None
        return GatewayUser(role=UserRole.User, name=principal.name, gateway_role=principal.role)


_CALLER: contextvars.ContextVar[GatewayUser | None] = contextvars.ContextVar(
    "opcua_caller", default=None
)


def caller() -> GatewayUser | None:
    """The user whose method call is running (None outside a call)."""
    return _CALLER.get()


_installed = False


def install_caller_context() -> None:
    """Make ``caller()`` name the session's user during its method calls (once a process)."""
    global _installed
    if _installed:
        return
    original: Callable[..., Awaitable[Any]] = InternalSession.call

    async def call(self: InternalSession, params: Any) -> Any:
        user = self.user if isinstance(self.user, GatewayUser) else None
        reset = _CALLER.set(user)
        try:
            return await original(self, params)
        finally:
            _CALLER.reset(reset)

    InternalSession.call = call
    _installed = True
