"""``rc233-gateway serve --config`` runs each loop in a line worker process: one killed mid-move
is restarted after its back-off; meanwhile its loop is down with the cause (503 with
Retry-After, ``/readyz``, ``/metrics``, the WebSocket's link event), the other loop and the
API go on, the move's operation is resolved by read-back once the new worker reads the
device, and a latched error outlives the worker until a client acknowledges it.

Real processes: two ``rc233-gateway sim --tcp`` (``RestartRig``) outlive the workers; the
worker is found as the child process of ``serve`` whose start line names its loop.
"""

from __future__ import annotations

import asyncio
import json
import os
import re
import signal
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import httpx

from tests.support.restart_rig import WAIT, Gateway, RestartRig
from tests.support.ws_events import Events, is_link, worker_sample, ws_events

#: Real time: a 9,000-pulse move takes some 4 s, still going when its worker is killed.
SCALE = 1.0
MOVE = {"position": 9000, "unit": "pulse"}
#: Real seconds a dead worker stays down here: time for the checks of the outage, on a busy
#: machine too.
BACKOFF = 6.0

CELL = """
state_dir = "{state}"

[engine]
workers = [["main"], ["side"]]
restart_backoff = [{backoff}]

[[loops]]
name = "main"
port = "socket://127.0.0.1:{main}"
[[loops.controllers]]
body = "1"
name = "stage"
[[loops.controllers.axes]]
motor = 1
name = "x"

[[loops]]
name = "side"
port = "socket://127.0.0.1:{side}"
[[loops.controllers]]
body = "1"
name = "feeder"
[[loops.controllers.axes]]
motor = 1
name = "f"
"""


def _port(rig: RestartRig) -> str:
    found = re.search(r"socket://127\.0\.0\.1:(\d+)", rig.config.read_text("utf-8"))
    assert found
    return found[1]


@asynccontextmanager
async def _cell(tmp_path: Path) -> AsyncIterator[tuple[RestartRig, Gateway]]:
    """Two simulated loops, each its own process, and a gateway on both (both loops up)."""
    (tmp_path / "main").mkdir()
    (tmp_path / "side").mkdir()
    main, side = RestartRig(tmp_path / "main", SCALE), RestartRig(tmp_path / "side", SCALE)
    await asyncio.gather(main.start_sim(), side.start_sim())
    cell = CELL.format(state=main.state_dir, backoff=BACKOFF, main=_port(main), side=_port(side))
    main.config.write_text(cell, "utf-8")
    try:
        gateway = await main.serve()
        yield main, gateway
    finally:
        await main.close()
        await side.close()


def _worker_pid(gateway: Gateway, loop: str) -> int:
    """The pid of the worker running ``loop``, a child of ``serve`` (from its start line)."""
    lines = [line for line in gateway.log if f"for the loops {loop}" in line]
    found = re.search(r"line worker \S+ started \(pid (\d+)\)", lines[-1])
    assert found, lines
    pid = int(found[1])
    with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
        parent = int(stat.read().rsplit(")", 1)[1].split()[1])
    assert parent == gateway.process.pid  # a child of serve, not some other process
    return pid


def _shows_ems(event: dict[str, Any], axis: str) -> bool:
    data = event.get("data") or {}
    return data.get("id") == axis and bool((data.get("errors") or {}).get("emergency"))


async def _loop_up(client: httpx.AsyncClient, events: Events, loop: str) -> None:
    if not (await client.get(f"/api/v1/loops/{loop}")).json()["up"]:
        await events.until(lambda e: is_link(e, loop, True))


async def test_a_worker_killed_mid_move_is_restarted_and_the_move_is_read_back(
    tmp_path: Path,
) -> None:
    async with (
        _cell(tmp_path) as (rig, gateway),
        httpx.AsyncClient(base_url=gateway.url, timeout=WAIT) as client,
        ws_events(gateway.url) as events,
    ):
        api = "/api/v1"
        await _loop_up(client, events, "side")
        metrics = (await client.get("/metrics")).text
        assert worker_sample(metrics, "rc233_worker_up", "main") == 1
        assert worker_sample(metrics, "rc233_worker_restarts_total", "main") == 0
        started = await client.post(f"{api}/axes/x/move", json=MOVE)
        assert started.status_code == 202, started.text
        op = started.json()["id"]
        await events.until(lambda e: (e.get("data") or {}).get("id") == op
                           and e["data"]["state"] == "moving")  # fmt: skip

        killed_at = len(events.seen)
        os.kill(_worker_pid(gateway, "main"), signal.SIGKILL)
        down = await events.until(lambda e: is_link(e, "main", False, "killed by SIGKILL"))
        assert down["data"]["retry_after"] == BACKOFF
        assert f"restarting in {BACKOFF:g} s" in down["data"]["cause"]
        # The outage: requests to the loop are refused with when to ask again ...
        refused = await client.post(f"{api}/axes/x/move", json={**MOVE, "position": 0})
        assert refused.status_code == 503, refused.text
        assert 1 <= int(refused.headers["retry-after"]) <= BACKOFF
        assert "killed by SIGKILL" in refused.json()["detail"]
        ready = await client.get("/readyz")
        assert ready.status_code == 503
        assert ready.json()["loops_down"] == ["main"]
        assert "main" in ready.json()["detail"] and "killed by SIGKILL" in ready.json()["detail"]
        metrics = (await client.get("/metrics")).text
        assert worker_sample(metrics, "rc233_worker_up", "main") == 0
        assert worker_sample(metrics, "rc233_worker_restarts_total", "main") == 1
        assert worker_sample(metrics, "rc233_worker_up", "side") == 1
        # ... while the other loop, in its own worker, moves as before.
        side = await client.post(f"{api}/axes/f/move?wait=true", json={**MOVE, "position": 300})
        assert side.status_code == 200 and side.json()["state"] == "done", side.text
        assert not any(is_link(e, "main", True) for e in events.seen[killed_at:])  # still down

        # The new worker reads the controller: the move's end is read back, not guessed.
        unknown = (await client.get(f"{api}/operations/{op}")).json()
        assert unknown["state"] == "unknown", unknown
        resolved = await events.until(lambda e: (e.get("data") or {}).get("id") == op
                                      and e["data"]["state"] in ("done", "failed"))  # fmt: skip
        assert resolved["data"]["state"] == "done", resolved
        assert resolved["data"]["position"] == 9000
        assert (await rig.axis("1", 1))["position"] == 9000
        assert (await client.get("/readyz")).status_code == 200
        metrics = (await client.get("/metrics")).text
        assert worker_sample(metrics, "rc233_worker_up", "main") == 1
        assert worker_sample(metrics, "rc233_worker_restarts_total", "main") == 1
        assert worker_sample(metrics, "rc233_worker_restarts_total", "side") == 0
    assert any("line worker main was killed by SIGKILL" in line for line in gateway.log)


async def test_a_latched_error_outlives_its_worker_until_acknowledged(tmp_path: Path) -> None:
    async with (
        _cell(tmp_path) as (rig, gateway),
        httpx.AsyncClient(base_url=gateway.url + "/api/v1", timeout=WAIT) as client,
        ws_events(gateway.url) as events,
    ):
        await rig.control(op="ems", body="1", pressed=True)
        await events.until(lambda e: _shows_ems(e, "main.1.1"))
        await rig.control(op="ems", body="1", pressed=False)
        assert (await client.get("/axes/x")).json()["errors"]["emergency"] is True

        first = _worker_pid(gateway, "main")
        os.kill(first, signal.SIGKILL)
        await events.until(lambda e: is_link(e, "main", False, "killed by SIGKILL"))
        # Switched off and on while nobody watched: the controller holds no error any more.
        await rig.control(op="power_cycle", body="1")
        await events.until(lambda e: is_link(e, "main", True))
        events.seen.clear()
        # The new worker reads the controller again (the axis current, no longer stale): it
        # reports no error and the new worker's cache latched none, but the client has not
        # acknowledged the one it saw, so it still shows.
        fresh = await events.until(lambda e: (e.get("data") or {}).get("id") == "main.1.1"
                                   and e["data"]["stale"] is False)  # fmt: skip
        assert fresh["data"]["errors"]["emergency"] is True, fresh
        assert _worker_pid(gateway, "main") != first
        view = (await client.get("/axes/x")).json()
        assert view["errors"]["emergency"] is True and view["stale"] is False, view
        ctl = (await client.get("/controllers/main.1")).json()
        assert "emergency" in json.dumps(ctl["latched"]), ctl

        acked = await client.post("/axes/x/errors/ack", json={})
        assert acked.status_code == 200 and acked.json()["errors"]["emergency"] is False
        assert (await client.get("/axes/x")).json()["errors"]["emergency"] is False
