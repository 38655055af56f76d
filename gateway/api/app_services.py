"""The services an app serves: held once (``hold_services``), read through one getter each.

``create_app`` holds the ``Services`` the composition root built as ``app.state.services``;
routes, dependencies and middleware read a service only through the getters here (each takes
the request or WebSocket, ``HTTPConnection``), never from ``app.state`` themselves. The getters
are plain functions: a route's dependency wraps one in an ``async def`` (``routes/deps.py``),
since FastAPI runs a plain dependency in its thread pool, a hop each request. The app's own
objects (its auth mode, metrics, idempotency store) are the HTTP face's, not services, and
stay with their ``install_*``.
"""

from __future__ import annotations

from starlette.applications import Starlette
from starlette.requests import HTTPConnection

from gateway.service.axes import AxisService
from gateway.service.baud import BaudChanger
from gateway.service.controllers import ControllerService
from gateway.service.leases import Leases
from gateway.service.operations import Operations
from gateway.service.services import Services
from gateway.service.stops import StopAll

__all__ = [
    "axes_of",
    "baud_of",
    "controllers_of",
    "held_services",
    "hold_services",
    "leases_of",
    "operations_of",
    "services_of",
    "stops_of",
]


def hold_services(app: Starlette, services: Services) -> None:
    """Make ``services`` what the getters of ``app``'s requests return."""
    app.state.services = services


def held_services(conn: HTTPConnection) -> Services | None:
    """The services of ``conn``'s app; None for an app built without them (a test's app of
    one router)."""
    services = getattr(conn.app.state, "services", None)
    return services if isinstance(services, Services) else None


def services_of(conn: HTTPConnection) -> Services:
    """The services of ``conn``'s app (``create_app`` holds them)."""
    services = held_services(conn)
    assert services is not None, "the app holds no services (hold_services was not called)"
    return services


def leases_of(conn: HTTPConnection) -> Leases:
    """The control leases."""
    return services_of(conn).leases


def operations_of(conn: HTTPConnection) -> Operations:
    """The operations book."""
    return services_of(conn).operations


def axes_of(conn: HTTPConnection) -> AxisService:
    """The axis service."""
    return services_of(conn).axes


def controllers_of(conn: HTTPConnection) -> ControllerService:
    """The controller service."""
    return services_of(conn).controllers


def stops_of(conn: HTTPConnection) -> StopAll:
    """Stop-all (controllers and loops)."""
    return services_of(conn).stops


def baud_of(conn: HTTPConnection) -> BaudChanger:
    """The baud changer."""
    return services_of(conn).baud
