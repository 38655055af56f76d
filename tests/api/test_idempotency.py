"""``Idempotency-Key``: a retried POST returns the first result instead of acting again."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator

import httpx
import pytest
from fastapi import FastAPI, Response

from gateway.api.middleware.idempotency import install_idempotency
from gateway.api.problems import install_problem_handlers
from gateway.api.security import AuthConfig, install_security
from gateway.service.store import StateStore
from tests.support.sim_app import auth, json_of, running_app


async def test_a_retried_move_moves_the_axis_once() -> None:
    async with running_app() as api:
        key = {"Idempotency-Key": "move-x-1"}
        mark = api.mark()
        first = await api.client.post(
            "/axes/x/move", json={"position": 1500, "unit": "pulse"}, headers=key
        )
        assert first.status_code == 202 and "idempotent-replayed" not in first.headers
        await api.operations.wait(json_of(first)["id"], 20)
        retry = await api.client.post(
            "/axes/x/move", json={"position": 1500, "unit": "pulse"}, headers=key
        )
        assert retry.status_code == 202
        assert retry.headers["idempotent-replayed"] == "true"
        assert retry.content == first.content  # the first operation, as first answered
        assert retry.headers["location"] == first.headers["location"]
        assert api.heard("1", mark).count("3") == 1  # one move on the wire (§10 3)
        assert api.position("1", 1) == 1500


async def test_a_retry_while_the_first_runs_waits_for_it() -> None:
    async with running_app() as api:
        key = {"Idempotency-Key": "home-z"}
        await api.client.post("/axes/z/move?wait=true", json={"position": 1000, "unit": "pulse"})
        mark = api.mark()
        one, two = await asyncio.gather(
            api.client.post("/axes/z/home?wait=true", json={"method": "0"}, headers=key),
            api.client.post("/axes/z/home?wait=true", json={"method": "0"}, headers=key),
        )
        assert one.status_code == two.status_code == 200
        assert one.content == two.content and json_of(one)["state"] == "done"
        assert sorted(r.headers.get("idempotent-replayed", "") for r in (one, two)) == ["", "true"]
        assert api.heard("2", mark).count("0") == 1


async def test_another_body_with_the_same_key_is_refused() -> None:
    async with running_app() as api:
        key = {"Idempotency-Key": "k-1"}
        await api.client.post("/axes/x/step?wait=true", json={"direction": "cw"}, headers=key)
        mark = api.mark()
        r = await api.client.post("/axes/x/step", json={"direction": "ccw"}, headers=key)
        assert r.status_code == 422
        assert json_of(r)["field"] == "header.Idempotency-Key"
        assert "8*" not in api.heard("1", mark)
        r = await api.client.post(
            "/axes/x/step", json={"direction": "cw"}, headers={"Idempotency-Key": ""}
        )
        assert r.status_code == 422


async def test_refusals_are_not_stored_and_keys_are_per_client() -> None:
    async with running_app(roles=True) as api:
        key = {"Idempotency-Key": "same"}
        await api.client.post("/axes/x/lease", headers=auth("alice"))
        r = await api.client.post(
            "/axes/x/step", json={"direction": "cw"}, headers=key | auth("bob")
        )
        assert r.status_code == 409  # leased: nothing done, nothing stored
        await api.client.delete("/axes/x/lease", headers=auth("alice"))
        r = await api.client.post(
            "/axes/x/step?wait=true", json={"direction": "cw"}, headers=key | auth("bob")
        )
        assert r.status_code == 200 and "idempotent-replayed" not in r.headers
        # alice's "same" key is hers: it acts
        r = await api.client.post(
            "/axes/x/step?wait=true", json={"direction": "cw"}, headers=key | auth("alice")
        )
        assert r.status_code == 200 and "idempotent-replayed" not in r.headers
        assert api.position("1", 1) == 2


class Clock:
    """A clock the test moves."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
async def counting() -> AsyncIterator[tuple[httpx.AsyncClient, list[int], Clock]]:
    """A tiny app whose POST counts its calls, behind the middleware (capacity 2, ttl 60)."""
    app = FastAPI()
    calls: list[int] = []
    clock = Clock()

    @app.post("/count")
    async def count(response: Response, status: int = 200) -> dict[str, int]:
        calls.append(1)
        response.status_code = status
        return {"calls": len(calls)}

    install_security(app, AuthConfig(no_auth=True))  # anyone may act: keys are kept
    install_problem_handlers(app)
    store = StateStore.memory()
    app.state.idempotency_store = install_idempotency(app, store, capacity=2, ttl=60, clock=clock)
    transport = httpx.ASGITransport(app=app)
    async with httpx.AsyncClient(transport=transport, base_url="http://localhost") as client:
        yield client, calls, clock
    await store.close()


async def test_store_is_bounded_and_expires(
    counting: tuple[httpx.AsyncClient, list[int], Clock],
) -> None:
    client, calls, clock = counting

    async def post(key: str, status: int = 200) -> httpx.Response:
        return await client.post(f"/count?status={status}", headers={"Idempotency-Key": key})

    assert (await post("a")).json() == {"calls": 1}
    assert (await post("a")).json() == {"calls": 1}
    await post("b")
    await post("c")  # capacity 2 in memory: "a" is dropped there, and kept in the state store
    replay = await post("a")
    assert replay.json() == {"calls": 1} and replay.headers["idempotent-replayed"] == "true"
    clock.now = 61  # every key expired, in memory and in the state store
    assert (await post("c")).json() == {"calls": 4}
    assert (await post("a")).json() == {"calls": 5}
    # 503 and 4xx are not stored (nothing was done); 504 and 500 are
    assert (await post("d", 503)).status_code == 503
    assert (await post("d", 503)).json() == {"calls": 7}
    assert (await post("e", 504)).json() == {"calls": 8}
    replay = await post("e", 504)
    assert replay.status_code == 504 and replay.json() == {"calls": 8}
    # no key: no store
    await client.post("/count")
    await client.post("/count")
    assert len(calls) == 10
