"""Role enumeration over every route of the real app.

Every mutating route refuses a viewer token with 403; every admin route refuses an operator
with 403; the routes the issue names as admin-only are admin routes. Nothing of a refused
request reaches the wire. The list of routes comes from the app itself, so a route added
later without its role dependency fails here.
"""

from __future__ import annotations

import re

import pytest

from gateway.api.security import route_roles
from gateway.protocol.command_text import parse
from gateway.service.roles import Role
from tests.support.sim_app import Api, auth, running_app

#: Values for the path parameters of the routes (ids of ``serve --simulate``).
PATH_VALUES = {
    "id": None,  # by the route's resource, see _url
    "loop": "sim",
    "n": "1",
    "bit": "0",
    "port": "inputs",
    "motor": "1",
    "buffer": "1",
    "counter": "1",
}

#: What the issue makes admin-only: raw, EEPROM, programs (upload, autostart), mode, trace.
ADMIN_ONLY = [
    ("POST", "/api/v1/loops/{loop}/raw"),
    ("POST", "/api/v1/controllers/{id}/eeprom/save"),
    ("POST", "/api/v1/controllers/{id}/eeprom/load"),
    ("POST", "/api/v1/controllers/{id}/eeprom/erase"),
    ("PUT", "/api/v1/controllers/{id}/program"),
    ("PUT", "/api/v1/controllers/{id}/program/autostart"),
    ("PUT", "/api/v1/controllers/{id}/mode"),
    ("GET", "/api/v1/loops/{loop}/trace"),
    ("GET", "/api/v1/audit"),
]


def _url(path: str) -> str:
    resource = "sim.1.1" if path.startswith("/api/v1/axes") else "sim.1"
    if path.startswith("/api/v1/operations"):
        resource = "op-unknown"
    return re.sub(
        r"\{(\w+)\}", lambda m: PATH_VALUES.get(m.group(1)) or resource, path
    ).removeprefix("/api/v1")


@pytest.fixture
async def api() -> Api:  # type: ignore[misc]
    async with running_app(("1",), roles=True) as running:
        yield running


def _routes(api: Api) -> list[tuple[str, str, Role | None]]:
    return sorted(
        (method, r.path, r.role)
        for r in route_roles(api.app)
        for method in r.methods
        if method != "HEAD"
    )


async def test_every_mutating_route_needs_an_operator_and_refuses_a_viewer(api: Api) -> None:
    mutating = [(m, p, role) for m, p, role in _routes(api) if m in {"POST", "PUT", "DELETE"}]
    assert len(mutating) >= 30  # the app's real routes, not an empty list
    mark = api.mark()
    for method, path, role in mutating:
        assert role in (Role.OPERATOR, Role.ADMIN), (method, path, role)
        reply = await api.client.request(method, _url(path), json={}, headers=auth("viewer"))
        assert reply.status_code == 403, (method, path, reply.text)
        assert reply.headers["content-type"] == "application/problem+json"
        assert reply.json()["required_role"] in ("operator", "admin")
    # The poller's reads go on; nothing else reached the line.
    assert [t for t in api.heard(since=mark) if not parse(t).reply_format.has_data] == []


async def test_admin_routes_refuse_an_operator(api: Api) -> None:
    routes = _routes(api)
    admin = {(m, p) for m, p, role in routes if role is Role.ADMIN}
    assert set(ADMIN_ONLY) <= admin, set(ADMIN_ONLY) - admin
    for method, path in sorted(admin):
        reply = await api.client.request(method, _url(path), json={}, headers=auth("operator"))
        assert reply.status_code == 403, (method, path, reply.text)
        assert reply.json()["required_role"] == "admin"


async def test_reads_need_a_token_and_a_viewer_is_enough(api: Api) -> None:
    reads = [(m, p) for m, p, role in _routes(api) if m == "GET" and role is Role.VIEWER]
    assert ("GET", "/api/v1/axes") in reads
    for method, path in reads:
        if "{" in path:
            continue  # the listings suffice: the same dependency guards the items
        anonymous = await api.client.request(method, _url(path))
        assert anonymous.status_code == 401, (path, anonymous.text)
        assert anonymous.headers["www-authenticate"].startswith("Bearer")
        viewer = await api.client.request(method, _url(path), headers=auth("viewer"))
        assert viewer.status_code == 200, (path, viewer.text)
