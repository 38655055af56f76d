"""The cached read of one axis, answered without routing: ``GET /api/v1/axes/{id}``.

The read dashboards and MES clients poll is the cheapest thing the API does, yet routed through
FastAPI it cost twice a bare route: path matching over every router, dependency solving for
the bearer scheme and the service, validating the returned view against its model and
encoding it (bench/line_outside.py, phase ``http``). ``AxisReadPath`` is a pure ASGI layer,
innermost of the app's middlewares (so the security headers, the metrics, the access line,
CORS and the catch-all apply to its answers as to any other), that answers the plain read
itself, and only when the routed read would answer 200:

* ``GET``, the path ``{prefix}/axes/{id}`` and no query string (``?fresh=true`` and anything
  else goes the routed way);
* a caller the routed read lets in: the same bearer header rule as FastAPI's ``HTTPBearer``
  (``security._bearer_of``), the same token book, and a viewer or above (every role);
* an axis the topology knows by that id or name.

Anything else (no token, an unknown one, an unknown axis) is handed to the routed app, which
gives the problems it always gave. The body is the view ``axis_view`` builds from the state
cache's record of the axis, its controller's control view and the topology, encoded once and
kept until one of them changes: the cache's records are frozen dataclasses replaced on every
change, so the record's identity says whether anything of the axis changed, and the control
view (built anew, a few fields) is compared by value. The bytes are those the routed read
sends (tests/api/test_read_path.py compares them), and ``scope["route"]`` is set to the
routed read's route, so the metrics count the request under ``/api/v1/axes/{id}``.
"""

from __future__ import annotations

from dataclasses import dataclass

from fastapi import FastAPI
from fastapi.routing import APIRoute
from starlette.routing import BaseRoute
from starlette.types import ASGIApp, Receive, Scope, Send

from gateway.api.auth_failures import failures_of
from gateway.api.routes import axes as routes_axes
from gateway.api.security import api_routes, auth_of_scope, bearer_of_headers
from gateway.errors import NotFoundError
from gateway.service.control import ControlView
from gateway.service.roles import Role
from gateway.service.runtime.bus_types import AxisState
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import AxisRef
from gateway.service.views import axis_view

__all__ = ["AxisReadPath", "read_route"]


def read_route(app: object) -> BaseRoute | None:
    """The route of ``routes_axes.get_axis`` as ``app`` serves it (what FastAPI puts in
    ``scope["route"]``), found the way the metrics find templates (``api_routes``)."""
    if not isinstance(app, FastAPI):
        return None
    for route in api_routes(app):
        original = route.original
        if isinstance(original, APIRoute) and original.endpoint is routes_axes.get_axis:
            return original
    return None


@dataclass(frozen=True)
class _Encoded:
    """One axis's answer and what it was built from."""

    ref: AxisRef
    state: AxisState
    control: ControlView
    headers: list[tuple[bytes, bytes]]
    body: bytes


class AxisReadPath:
    """Answer ``GET {prefix}/axes/{id}`` (no query) from the cached, encoded view."""

    def __init__(self, app: ASGIApp, runtime: Runtime, prefix: str) -> None:
        self.app = app
        self.runtime = runtime
        self.start = f"{prefix}/axes/"
        self.route: BaseRoute | None = None  # the routed read's, for the metrics' template
        self._encoded: dict[str, _Encoded] = {}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """The ASGI entry point."""
        if scope["type"] == "http" and scope["method"] == "GET" and not scope["query_string"]:
            ident = self._ident(scope)
            encoded = None if ident is None else self._answer(scope, ident)
            if encoded is not None and self._route(scope) is not None:
                scope["route"] = self.route
                # A copy: the layers outside add their headers to the list they are given.
                headers = list(encoded.headers)
                await send({"type": "http.response.start", "status": 200, "headers": headers})
                await send({"type": "http.response.body", "body": encoded.body})
                return
        await self.app(scope, receive, send)

    def _route(self, scope: Scope) -> BaseRoute | None:
        # Found at the first read, when the app's routes are all in place.
        if self.route is None:
            self.route = read_route(scope.get("app"))
        return self.route

    def _ident(self, scope: Scope) -> str | None:
        path: str = scope["path"]
        root: str = scope.get("root_path", "")
        if root and path.startswith(root):
            path = path[len(root) :]
        if not path.startswith(self.start):
            return None
        ident = path[len(self.start) :]
        # The route's {id} is one path segment, not empty (Starlette's [^/]+).
        return ident if ident and "/" not in ident else None

    def _answer(self, scope: Scope, ident: str) -> _Encoded | None:
        """The encoded view of ``ident``; None when the routed read must answer."""
        # Who is not let in (no token, an unknown one, a role below viewer) gets the routed
        # read's problem.
        # An address made to wait after wrong tokens gets the routed read's 429: a right
        # guess answered here would tell it apart (gateway.api.auth_failures).
        failures = failures_of(scope)
        client = scope.get("client")
        if failures is not None and client and failures.retry_after(client[0]) is not None:
            return None
        principal = auth_of_scope(scope).authenticate(bearer_of_headers(scope), "")
        if principal is None or not principal.role.allows(Role.VIEWER):
            return None
        runtime = self.runtime
        try:
            ref = runtime.topology.axis(ident)
            controller = runtime.topology.controller(ref.controller_id)
        except NotFoundError:
            return None
        state = runtime.state.axis(ref.loop, ref.body, ref.motor)
        control = runtime.control.view(controller)
        cached = self._encoded.get(ident)
        if (
            cached is not None
            and cached.state is state
            and cached.ref is ref
            and cached.control == control
        ):
            return cached
        body = axis_view(ref, state, control).model_dump_json().encode()
        headers = [
            (b"content-length", str(len(body)).encode("latin-1")),
            (b"content-type", b"application/json"),
        ]
        encoded = _Encoded(ref, state, control, headers, body)
        self._encoded[ident] = encoded
        return encoded
