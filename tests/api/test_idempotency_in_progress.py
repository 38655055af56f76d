"""A keyed request is recorded ``in progress`` before its route acts: a retry after the
process died between acting and answering is told the outcome is unknown and acts no more;
when the record cannot be written, the request is refused 503 and nothing acts (a stop
excepted). PUTs are kept like POSTs."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
from fastapi import FastAPI, Response

from gateway.api.middleware.idempotency import install_idempotency
from gateway.api.problems import install_problem_handlers
from gateway.api.security import AuthConfig, install_security
from gateway.service.store import StateStore
from gateway.service.store.records import RequestKey, StoredKey, load_key, request_key
from tests.support.sim_app import auth, running_app


@dataclass
class Acts:
    """What the routes did, and the key record each saw on disk when it acted."""

    calls: list[str] = field(default_factory=list)
    seen: list[StoredKey | None] = field(default_factory=list)
    entered: asyncio.Event = field(default_factory=asyncio.Event)
    release: asyncio.Event = field(default_factory=asyncio.Event)


def _app(store: StateStore, acts: Acts) -> FastAPI:
    app = FastAPI()

    async def act(name: str) -> None:
        key: RequestKey | None = request_key.get()
        assert key is not None
        acts.seen.append(await store.run(lambda c: load_key(c, key.ident, key.created)))
        acts.calls.append(name)

    @app.post("/controllers/stage/program/run")
    async def run(response: Response, status: int = 200) -> dict[str, int]:
        await act("run")
        response.status_code = status
        return {"runs": acts.calls.count("run")}

    @app.post("/controllers/stage/hold")
    async def hold() -> dict[str, str]:
        await act("hold")
        acts.entered.set()
        await acts.release.wait()
        return {"held": "released"}

    @app.post("/axes/x/stop")
    async def stop() -> dict[str, str]:
        await act("stop")
        return {"stopped": "x"}

    @app.put("/controllers/stage/positions/1")
    async def put_position() -> dict[str, int]:
        await act("put")
        return {"puts": acts.calls.count("put")}

    install_security(app, AuthConfig(no_auth=True))  # anyone may act: keys are kept
    install_problem_handlers(app)
    install_idempotency(app, store)
    return app


@contextlib.asynccontextmanager
async def _client(store: StateStore, acts: Acts) -> AsyncIterator[httpx.AsyncClient]:
    transport = httpx.ASGITransport(app=_app(store, acts))
    async with httpx.AsyncClient(transport=transport, base_url="http://gw") as client:
        yield client


async def test_the_key_is_on_disk_in_progress_before_the_route_acts() -> None:
    store, acts = StateStore.memory(), Acts()
    try:
        async with _client(store, acts) as client:
            key = {"Idempotency-Key": "run-1"}
            first = await client.post("/controllers/stage/program/run", headers=key)
            assert first.json() == {"runs": 1}
            assert acts.seen[0] is not None and acts.seen[0].in_progress
            retry = await client.post("/controllers/stage/program/run", headers=key)
            assert retry.json() == {"runs": 1} and retry.headers["idempotent-replayed"] == "true"
            assert acts.calls == ["run"]
    finally:
        await store.close()


async def test_a_retry_after_a_death_mid_request_is_outcome_unknown_and_acts_no_more(
    tmp_path: Path,
) -> None:
    key = {"Idempotency-Key": "mes-run-77"}
    store, acts = await StateStore.open(tmp_path / "state"), Acts()
    try:
        async with _client(store, acts) as client:
            first = asyncio.ensure_future(client.post("/controllers/stage/hold", headers=key))
            await asyncio.wait_for(acts.entered.wait(), 10)
            first.cancel()  # the process goes away: no response, nothing recorded after
            with contextlib.suppress(asyncio.CancelledError):
                await first
    finally:
        await store.close()

    store, after = await StateStore.open(tmp_path / "state"), Acts()  # the restart
    after.release.set()
    try:
        async with _client(store, after) as client:
            retry = await client.post("/controllers/stage/hold", headers=key)
            again = await client.post("/controllers/stage/hold", headers=key)
            other = await client.post("/controllers/stage/hold", headers={"Idempotency-Key": "n"})
    finally:
        await store.close()
    assert retry.status_code == 409, retry.text
    assert retry.headers["idempotent-replayed"] == "true"
    problem = retry.json()
    assert problem["type"] == "urn:rc233-gateway:problem:idempotency-outcome-unknown"
    assert problem["field"] == "header.Idempotency-Key" and problem["outcome"] == "unknown"
    assert problem["key"] == "mes-run-77" and problem["accepted"].endswith("+00:00")
    assert "mes-run-77" in problem["detail"] and "may or may not have acted" in problem["detail"]
    assert "/api/v1/audit" in problem["detail"]
    assert again.status_code == 409 and again.json()["type"] == problem["type"]
    assert acts.calls == ["hold"] and after.calls == ["hold"]  # only the fresh key acted
    assert other.status_code == 200


async def test_a_key_that_cannot_be_recorded_is_refused_503_and_nothing_acts() -> None:
    store, acts = StateStore.memory(), Acts()
    await store.run(lambda c: c.execute("PRAGMA query_only = ON"))  # writes fail, as on EROFS
    try:
        async with _client(store, acts) as client:
            key = {"Idempotency-Key": "run-2"}
            refused = await client.post("/controllers/stage/program/run", headers=key)
            assert refused.status_code == 503, refused.text
            assert refused.headers["retry-after"] == "5"
            problem = refused.json()
            assert problem["type"] == "urn:rc233-gateway:problem:state-unavailable"
            assert problem["field"] == "header.Idempotency-Key"
            assert problem["outcome"] == "not_done" and "run-2" in problem["detail"]
            assert acts.calls == []
            # a stop is never refused for its record: stopping twice does no harm
            stopped = await client.post("/axes/x/stop", headers={"Idempotency-Key": "stop-1"})
            assert stopped.status_code == 200 and acts.calls == ["stop"]

            await store.run(lambda c: c.execute("PRAGMA query_only = OFF"))
            retry = await client.post("/controllers/stage/program/run", headers=key)
            assert retry.status_code == 200 and "idempotent-replayed" not in retry.headers
            assert acts.calls == ["stop", "run"]
    finally:
        await store.close()


async def test_an_answer_without_acting_takes_the_record_away_so_a_retry_acts() -> None:
    store, acts = StateStore.memory(), Acts()
    try:
        async with _client(store, acts) as client:
            key = {"Idempotency-Key": "run-3"}
            refused = await client.post("/controllers/stage/program/run?status=409", headers=key)
            assert refused.status_code == 409
            seen = acts.seen[0]
            assert seen is not None and seen.in_progress
            retry = await client.post("/controllers/stage/program/run?status=409", headers=key)
            assert retry.status_code == 409 and "idempotent-replayed" not in retry.headers
            assert acts.calls == ["run", "run"]  # not "outcome unknown": it acted again
    finally:
        await store.close()


async def test_a_keyed_put_is_replayed_and_acts_once() -> None:
    store, acts = StateStore.memory(), Acts()
    try:
        async with _client(store, acts) as client:
            key = {"Idempotency-Key": "put-1"}
            first = await client.put("/controllers/stage/positions/1", headers=key)
            retry = await client.put("/controllers/stage/positions/1", headers=key)
            assert first.json() == retry.json() == {"puts": 1}
            assert retry.headers["idempotent-replayed"] == "true"
            assert acts.calls == ["put"]
    finally:
        await store.close()


async def test_keys_sent_by_someone_who_may_not_act_are_not_kept() -> None:
    """A flood of keyed requests with a wrong token, or a viewer's, costs the state store no
    write (each would be a synced transaction): only a request that may act has its key kept."""
    store = StateStore.memory()
    move = {"position": 10, "unit": "pulse"}

    def writes() -> Any:
        return store.run(lambda c: c.total_changes)

    try:
        async with running_app(("1",), roles=True, store=store) as api:
            before = await writes()
            for n, who in enumerate(({"Authorization": "Bearer wrong"}, auth("viewer"))):
                headers = {**who, "Idempotency-Key": f"flood-{n}"}
                r = await api.client.post("/axes/x/move", json=move, headers=headers)
                assert r.status_code in (401, 403), r.text
            assert await writes() == before
            headers = {**auth("operator"), "Idempotency-Key": "real-1"}
            r = await api.client.post("/axes/x/move", json=move, headers=headers)
            assert r.status_code == 202, r.text
            kept = "SELECT count(*) FROM idempotency_keys"
            assert await store.run(lambda c: c.execute(kept).fetchone()[0]) == 1
    finally:
        await store.close()
