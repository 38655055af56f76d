"""Headers on every answer, and the pages outside the API that are open or need a token."""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import httpx
import pytest

from gateway.api.app import create_app
from gateway.api.security import AuthConfig, TokenBook, TokenEntry, hash_token
from gateway.compose import compose
from gateway.service.roles import Role
from gateway.service.runtime.runtime import Runtime
from gateway.service.runtime.simulated import SIM_LOOP, simulated_config
from gateway.transport.pipe import PipeTransport
from tests.support.sim_app import Api, auth, running_app

ROOT = "http://localhost"


def _never() -> Any:
    raise OSError("this app never opens its line")


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app(("1",), roles=True) as api:
        yield api


@pytest.mark.parametrize(
    ("method", "url", "status"),
    [
        ("GET", "/axes", 200),
        ("GET", "/axes/nowhere", 404),
        ("POST", "/axes/x/stop", 200),
        ("POST", "/axes/x/move", 422),
        ("GET", f"{ROOT}/metrics", 200),
        ("GET", f"{ROOT}/readyz", 200),
        ("GET", "/docs", 200),
        ("GET", "/openapi.json", 200),
    ],
)
async def test_every_answer_is_nosniff_no_store_and_not_frameable(
    api: Api, method: str, url: str, status: int
):
    response = await api.client.request(method, url, headers=auth("operator"), json={})
    assert response.status_code == status, response.text
    assert response.headers["x-content-type-options"] == "nosniff"
    assert response.headers["x-frame-options"] == "DENY"
    if url == "/docs":
        # The docs page is the dashboard's static Swagger UI: revalidated at every load, with
        # the dashboard's own policy (its own origin only), framing refused all the same.
        assert response.headers["cache-control"] == "no-cache"
        policy = response.headers["content-security-policy"]
        assert "frame-ancestors 'none'" in policy and "default-src 'self'" in policy
    else:
        assert response.headers["cache-control"] == "no-store"
        assert response.headers["content-security-policy"] == "frame-ancestors 'none'"


async def test_metrics_and_docs_are_open_by_default(api: Api):
    for url in (f"{ROOT}/metrics", "/docs", "/openapi.json"):
        assert (await api.client.get(url)).status_code == 200, url
    assert (await api.client.get("/axes")).status_code == 401  # the API itself is not


@pytest.fixture
async def closed() -> AsyncIterator[httpx.AsyncClient]:
    config = simulated_config(("1",))
    security = config.security.model_copy(update={"open_metrics": False, "open_docs": False})
    config = config.model_copy(update={"security": security})
    gateway = Runtime(config, transports={SIM_LOOP: PipeTransport(_never)})
    book = TokenBook([TokenEntry("vera", Role.VIEWER, hash_token("tok-vera"))])
    app = create_app(compose(gateway), auth=AuthConfig(book))
    transport = httpx.ASGITransport(app=app)
    async with httpx.AsyncClient(transport=transport, base_url=ROOT) as client:
        yield client


@pytest.mark.parametrize(
    "path", ["/metrics", "/api/v1/docs", "/api/v1/redoc", "/api/v1/openapi.json"]
)
async def test_closed_pages_need_a_token_of_any_role(closed: httpx.AsyncClient, path: str):
    refused = await closed.get(path)
    assert refused.status_code == 401
    assert refused.headers["content-type"] == "application/problem+json"
    assert refused.headers["www-authenticate"].startswith("Bearer")
    assert refused.headers["x-content-type-options"] == "nosniff"
    wrong = await closed.get(path, headers={"Authorization": "Bearer nope"})
    assert wrong.status_code == 401
    allowed = await closed.get(path, headers={"Authorization": "Bearer tok-vera"})
    assert allowed.status_code == 200
    assert (await closed.get("/healthz")).status_code == 200  # probes stay open
