"""Tokens in queries under encoded names (``?tok%65n=``, ``?%74oken=``): a server decodes the
name, so the logs and the audit must too. Through a real ``serve`` process: the WebSocket
line is uvicorn's own."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import httpx
from websockets.asyncio.client import connect

from tests.support.serve_process import TIME_SCALE, serve
from tests.support.token_cell import CELL, OPERATOR, VIEWER


async def test_encoded_token_names_are_masked_in_every_log_and_audit(tmp_path: Path) -> None:
    audit = tmp_path / "audit.jsonl"
    config = tmp_path / "cell.toml"
    config.write_text(CELL.format(audit=audit), "utf-8")
    options = ("--simulate", "--config", str(config), "--time-scale", str(TIME_SCALE))
    async with serve(tmp_path, *options) as served:
        ws = served.url.replace("http", "ws") + "/api/v1/ws"
        # The browser's way in, under an encoded name: taken (the server decodes the name).
        for name in ("tok%65n", "%74oken"):
            async with connect(f"{ws}?{name}={VIEWER}", open_timeout=30) as conn:
                await conn.send(json.dumps({"type": "ping", "id": "1"}))
                assert json.loads(await asyncio.wait_for(conn.recv(), 30))["type"] == "pong"
        async with httpx.AsyncClient(base_url=served.url + "/api/v1", timeout=30) as client:
            for name in ("tok%65n", "%74oken", "TOKEN", "access%5Ftoken"):
                stop = await client.post(
                    f"/axes/x/stop?{name}={OPERATOR}",
                    headers={"Authorization": f"Bearer {OPERATOR}",
                             "Content-Type": "application/json"},
                )  # fmt: skip
                assert stop.status_code == 200, stop.text
            # A query token is the WebSocket's alone: on HTTP it authenticates nobody.
            assert (await client.get(f"/axes?token={VIEWER}")).status_code == 401
            await client.post("/axes/x/stop?x=1", headers={"Content-Type": "application/json"})
    log = "".join(served.log)
    assert '"WebSocket /api/v1/ws" [accepted]' in log, log  # uvicorn's line: no query
    assert "/axes/x/stop?tok%65n=***" in log and "/axes/x/stop?%74oken=***" in log, log
    assert VIEWER not in log and OPERATOR not in log, log
    entries = [json.loads(line) for line in audit.read_text("utf-8").splitlines()]
    queries = [e["query"] for e in entries if e.get("token") == "mes"]
    assert "tok%65n=***" in queries and "access%5Ftoken=***" in queries, queries
    assert OPERATOR not in audit.read_text("utf-8")
