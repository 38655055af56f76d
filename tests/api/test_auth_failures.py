"""Wrong tokens: a back-off per client address, and one record per address an interval."""

from __future__ import annotations

import asyncio
import json
import logging
from pathlib import Path
from typing import Any

import httpx
import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed

from gateway.api.auth_failures import FREE_FAILURES, AuthFailures
from gateway.service.runtime.simulated import simulated_config
from tests.support.fake_clock import FakeClock
from tests.support.serve_process import TIME_SCALE, serve
from tests.support.sim_app import BASE, DECLARE_JSON, auth, running_app
from tests.support.token_cell import CELL, VIEWER

WRONG = {"Authorization": "Bearer not-a-token"}


async def test_wrong_tokens_from_one_address_are_made_to_wait(tmp_path: Path) -> None:
    async with running_app(("1",), roles=True, audit_log=tmp_path / "audit.jsonl") as api:
        for _ in range(FREE_FAILURES + 1):
            refused = await api.client.post("/axes/x/stop", headers=WRONG)
            assert refused.status_code == 401, refused.text
        throttled = await api.client.post("/axes/x/stop", headers=WRONG)
        assert throttled.status_code == 429, throttled.text
        assert throttled.headers["content-type"] == "application/problem+json"
        assert throttled.headers["retry-after"] == "1"
        # A right guess is not told apart while the address waits, on the plain read too.
        right = await api.client.post("/axes/x/stop", headers=auth("operator"))
        assert right.status_code == 429
        assert (await api.client.get("/axes/x", headers=auth("viewer"))).status_code == 429
        # Another address is not concerned.
        other = httpx.ASGITransport(app=api.app, client=("10.1.2.3", 5000))
        async with httpx.AsyncClient(
            transport=other, base_url=BASE, event_hooks=DECLARE_JSON
        ) as client:
            assert (await client.post("/axes/x/stop", headers=auth("operator"))).status_code == 200


def test_the_wait_doubles_and_the_memory_is_bounded() -> None:
    clock = FakeClock()
    records: list[dict[str, Any]] = []
    failures = AuthFailures(records.append, clock=clock, capacity=3)
    waits = []
    for _ in range(FREE_FAILURES + 4):
        failures.failed("192.0.2.1", "POST /x", guessed=True)
        waits.append(failures.retry_after("192.0.2.1"))
    assert waits[:FREE_FAILURES] == [None] * FREE_FAILURES
    assert waits[FREE_FAILURES:] == [1.0, 2.0, 4.0, 8.0]
    clock.now += 8.0
    assert failures.retry_after("192.0.2.1") is None
    # Missing tokens are no guesses: recorded, never waited for.
    for _ in range(50):
        failures.failed("192.0.2.2", "GET /y", guessed=False)
    assert failures.retry_after("192.0.2.2") is None
    for i in range(100):
        failures.failed(f"198.51.100.{i}", "POST /x", guessed=True)
    assert len(failures) == 3
    failures.close()
    # Each address forgotten had its count written: nothing is lost, nothing kept forever.
    by_client: dict[str, int] = {}
    for record in records:
        by_client[record["client"]] = by_client.get(record["client"], 0) + record["count"]
    assert by_client["192.0.2.1"] == FREE_FAILURES + 4 and by_client["192.0.2.2"] == 50
    assert all(by_client[f"198.51.100.{i}"] == 1 for i in range(100))


async def test_a_flood_of_wrong_tokens_is_one_record_an_interval(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "audit.jsonl"
    with caplog.at_level(logging.INFO):
        async with running_app(("1",), roles=True, audit_log=path) as api:
            # The whole flood at one instant of the book's clock: on a slow host 100 requests
            # could outlast a back-off, and a request after it is rightly a 401 again.
            api.app.state.auth_failures.clock = FakeClock()
            statuses = [
                (await api.client.post("/axes/x/stop", headers=WRONG, json={})).status_code
                for _ in range(100)
            ]
            missing = [(await api.client.post("/axes/x/stop")).status_code for _ in range(20)]
    assert statuses[: FREE_FAILURES + 1] == [401] * (FREE_FAILURES + 1)
    assert set(statuses[FREE_FAILURES + 1 :]) == {429} and set(missing) == {429}
    entries = [json.loads(line) for line in path.read_text("utf-8").splitlines()]
    failed = [e for e in entries if e.get("event") == "authentication_failed"]
    # The first at once, the rest summed once the interval passed (here: at shutdown).
    assert len(failed) == 2 and len(entries) == 2, entries
    assert failed[0]["count"] == 1 and failed[0]["status"] == 401
    assert sum(e["count"] + e["throttled"] for e in failed) == 120
    assert {e["client"] for e in failed} == {"127.0.0.1"}
    lines = [r for r in caplog.records if r.name.startswith("gateway")
             and r.levelno >= logging.INFO and "/axes/x/stop" in r.getMessage()]  # fmt: skip
    assert len(lines) == 2, [r.getMessage() for r in lines]


async def test_the_pending_count_is_written_when_the_interval_ends() -> None:
    written = asyncio.Event()
    records: list[dict[str, Any]] = []

    def record(entry: dict[str, Any]) -> None:
        records.append(entry)
        if len(records) == 2:
            written.set()

    failures = AuthFailures(record, interval=0.05)
    for _ in range(30):
        failures.failed("192.0.2.9", "POST /x", guessed=False)
    assert [r["count"] for r in records] == [1]
    await asyncio.wait_for(written.wait(), 10)
    assert [r["count"] for r in records] == [1, 29]


async def test_a_websocket_guessing_tokens_is_made_to_wait(tmp_path: Path) -> None:
    config = tmp_path / "cell.toml"
    config.write_text(CELL.format(audit=tmp_path / "audit.jsonl"), "utf-8")
    options = ("--simulate", "--config", str(config), "--time-scale", str(TIME_SCALE))
    async with serve(tmp_path, *options) as served:
        ws = served.url.replace("http", "ws") + "/api/v1/ws"
        codes = []
        for _ in range(FREE_FAILURES + 2):
            async with connect(f"{ws}?token=guess", open_timeout=30) as conn:
                with pytest.raises(ConnectionClosed):
                    await asyncio.wait_for(conn.recv(), 30)
                assert conn.close_code is not None
                codes.append(conn.close_code)
        assert codes == [4401] * (FREE_FAILURES + 1) + [4429], codes
        async with connect(f"{ws}?token={VIEWER}", open_timeout=30) as conn:
            with pytest.raises(ConnectionClosed):  # the right token waits too
                await asyncio.wait_for(conn.recv(), 30)
            assert conn.close_code == 4429 and "retry in" in (conn.close_reason or "")


async def test_a_closed_page_counts_wrong_tokens_too() -> None:
    config = simulated_config(("1",))
    security = config.security.model_copy(update={"open_metrics": False})
    config = config.model_copy(update={"security": security})
    async with running_app(("1",), roles=True, config=config) as api:
        metrics = "http://localhost/metrics"
        for _ in range(FREE_FAILURES + 1):
            assert (await api.client.get(metrics, headers=WRONG)).status_code == 401
        waited = await api.client.get(metrics, headers=auth("viewer"))
        assert waited.status_code == 429 and waited.headers["retry-after"] == "1"
        assert (await api.client.get("/axes", headers=auth("viewer"))).status_code == 429
