"""The cached read of one axis (``api.routes.axis_read_path``): the same answer as the routed read,
the same refusals, counted the same, and never older than the state cache."""

from __future__ import annotations

import dataclasses
from collections.abc import AsyncIterator
from typing import Any

import httpx
import pytest
from starlette.types import Receive, Scope, Send

from gateway.api.routes.axis_read_path import AxisReadPath
from gateway.api.security import AuthConfig, bearer_of_headers
from gateway.service.runtime.bus_types import AxisState
from gateway.service.runtime.simulated import SIM_LOOP
from tests.support.exposition import parse_exposition, value
from tests.support.sim_app import Api, auth, json_of, running_app

TEMPLATE = "/api/v1/axes/{id}"


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app(("1", "2"), roles=True) as api:
        yield api


def _record(api: Api, body: str = "1", motor: int = 1) -> AxisState:
    return api.runtime.state.axis(SIM_LOOP, body, motor)


async def _both(api: Api, ident: str) -> tuple[httpx.Response, httpx.Response]:
    """The cached read and the routed one (``?fresh=false``: a query, so routed) of ``ident``,
    taken while the state cache's record of the axis stayed the same (the poller replaces it
    as it reads; retried until a pair falls between two polls)."""
    for _ in range(200):
        before = _record(api)
        cached = await api.client.get(f"/axes/{ident}", headers=auth("viewer"))
        routed = await api.client.get(f"/axes/{ident}?fresh=false", headers=auth("viewer"))
        if _record(api) is before:
            return cached, routed
    raise AssertionError("the poller changed the axis between every pair of reads")


async def test_the_cached_read_sends_the_routed_reads_bytes_and_headers(api: Api) -> None:
    for ident in ("x", "sim.1.1"):
        cached, routed = await _both(api, ident)
        assert cached.status_code == routed.status_code == 200, cached.text
        assert cached.content == routed.content
        assert dict(cached.headers) == dict(routed.headers)
        assert cached.headers["cache-control"] == "no-store"
        assert cached.headers["x-content-type-options"] == "nosniff"
        assert json_of(cached)["id"] == "sim.1.1"


async def test_the_cached_read_refuses_as_the_routed_read_did(api: Api) -> None:
    r = await api.client.get("/axes/x")
    assert r.status_code == 401
    assert r.headers["content-type"] == "application/problem+json"
    assert r.headers["www-authenticate"] == 'Bearer realm="rc233-gateway"'
    r = await api.client.get("/axes/x", headers={"Authorization": "Bearer not-a-token"})
    assert r.status_code == 401
    assert 'error="invalid_token"' in r.headers["www-authenticate"]
    r = await api.client.get("/axes/x", headers={"Authorization": "Basic dG9rLXZpZXdlcg=="})
    assert r.status_code == 401
    r = await api.client.get("/axes/nowhere", headers=auth("viewer"))
    assert r.status_code == 404
    assert r.headers["content-type"] == "application/problem+json"
    assert "nowhere" in r.json()["detail"]
    # The scheme in any case, the token with spaces around it: as HTTPBearer reads it.
    token = auth("viewer")["Authorization"].split(" ", 1)[1]
    r = await api.client.get("/axes/x", headers={"Authorization": f"bEaReR   {token}  "})
    assert r.status_code == 200, r.text


async def test_the_cached_read_is_counted_under_the_route_template(api: Api) -> None:
    for ident in ("x", "y", "sim.1.1"):
        assert (await api.client.get(f"/axes/{ident}", headers=auth("viewer"))).status_code == 200
    r = await api.client.get("http://localhost/metrics")
    fams = parse_exposition(r.text)
    count = value(fams, "rc233_http_requests_total", route=TEMPLATE, method="GET", status="200")
    assert count == 3


async def test_the_cached_read_follows_every_change_of_the_axis(api: Api) -> None:
    first = json_of(await api.client.get("/axes/x", headers=auth("viewer")))
    r = await api.client.post(
        "/axes/x/move?wait=true",
        json={"position": first["position"] + 1500, "relative": False, "unit": "pulse"},
        headers=auth("operator"),
    )
    assert r.status_code == 200, r.text
    target = first["position"] + 1500
    await api.until(lambda: _record(api).position == target and not _record(api).moving)
    after = json_of(await api.client.get("/axes/x", headers=auth("viewer")))
    assert after["position"] == target == api.position()
    assert after["moving"] is False

    r = await api.client.put(
        "/controllers/sim.1/control", json={"state": "local"}, headers=auth("admin")
    )
    assert r.status_code == 200, r.text
    local = json_of(await api.client.get("/axes/x", headers=auth("viewer")))
    assert local["control"]["state"] == "local"
    r = await api.client.put(
        "/controllers/sim.1/control", json={"state": "remote"}, headers=auth("admin")
    )
    assert r.status_code == 200, r.text
    remote = json_of(await api.client.get("/axes/x", headers=auth("viewer")))
    assert remote["control"]["state"] == "remote"


def test_the_state_records_it_keys_on_are_frozen() -> None:
    # The cache asks whether the record is the same object: only true of records replaced,
    # never changed in place, on every change.
    assert AxisState.__dataclass_params__.frozen  # type: ignore[attr-defined]
    with pytest.raises(dataclasses.FrozenInstanceError):
        AxisState(1).position = 5  # type: ignore[misc]


# ---------------------------------------------------------------------- the layer alone


class _Routed:
    """The app behind the layer: records the requests handed to it."""

    def __init__(self) -> None:
        self.paths: list[str] = []

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        self.paths.append(scope["path"] + "?" + scope["query_string"].decode())
        await send({"type": "http.response.start", "status": 599, "headers": []})
        await send({"type": "http.response.body", "body": b"routed"})


async def test_the_layer_answers_only_a_plain_read_of_a_known_axis_by_a_known_caller(
    api: Api,
) -> None:
    routed = _Routed()
    layer = AxisReadPath(routed, api.runtime, "/api/v1")

    async def call(path: str, query: bytes = b"", headers: Any = ()) -> tuple[int, bytes]:
        sent: list[dict[str, Any]] = []
        scope = {
            "type": "http",
            "method": "GET",
            "path": path,
            "root_path": "",
            "query_string": query,
            "headers": list(headers),
            "app": api.app,  # its auth (install_security) and routes
        }

        async def receive() -> dict[str, Any]:
            raise AssertionError("a read has no body to receive")

        async def send(message: Any) -> None:
            sent.append(message)

        await layer(scope, receive, send)
        return sent[0]["status"], sent[1]["body"]

    viewer = [(b"authorization", auth("viewer")["Authorization"].encode())]
    status, body = await call("/api/v1/axes/x", headers=viewer)
    assert status == 200 and b'"id":"sim.1.1"' in body
    assert routed.paths == []
    for path, query, headers in (
        ("/api/v1/axes/x", b"", ()),  # no token
        ("/api/v1/axes/x", b"fresh=true", viewer),  # a query: routed
        ("/api/v1/axes/nowhere", b"", viewer),  # unknown axis: the routed 404
        ("/api/v1/axes/x/speed", b"", viewer),  # another route
        ("/api/v1/axes/", b"", viewer),
    ):
        assert await call(path, query, headers) == (599, b"routed")
    assert len(routed.paths) == 5


def test_bearer_of_headers_reads_the_first_authorization_header_like_http_bearer() -> None:
    def of(*values: bytes) -> str | None:
        return bearer_of_headers({"headers": [(b"authorization", v) for v in values]})

    assert of(b"Bearer abc") == "abc"
    assert of(b"bearer  abc ") == "abc"
    assert of(b"Basic abc") is None
    assert of(b"Bearer ") is None
    assert of(b"Bearer") is None
    assert of(b"Basic abc", b"Bearer abc") is None  # the first one counts
    assert of() is None
    assert AuthConfig().authenticate(of(b"Bearer abc"), "") is None  # fail closed
