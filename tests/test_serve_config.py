"""``serve --simulate --config``: a shared demo with the file's tokens, and no token in its log.

The real command in a process of its own, as a user starts it; its log is what it prints.
"""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import sys
from pathlib import Path

import httpx
from websockets.asyncio.client import connect

from gateway.api.security import hash_token

VIEWER = "VIEWtok-5f3a9c0e1d2b"
OPERATOR = "OPERtok-77aa19c3b4e2"
WAIT = 30.0

CELL = f"""
audit_log = "{{audit}}"

[security]
[[security.tokens]]
name = "dashboard"
role = "viewer"
sha256 = "{hash_token(VIEWER)}"

[[security.tokens]]
name = "mes"
role = "operator"
sha256 = "{hash_token(OPERATOR)}"

[[loops]]
name = "cell"
port = "/dev/serial/by-id/not-here"   # replaced by a simulated loop

[[loops.controllers]]
body = "4"
name = "press"

[[loops.controllers.axes]]
motor = 1
name = "ram"
unit = "mm"
units_per_pulse = 0.01
"""


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


async def test_a_simulated_cell_from_a_file_asks_for_its_tokens_and_logs_none(
    tmp_path: Path,
) -> None:
    path = tmp_path / "cell.toml"
    path.write_text(CELL.format(audit=tmp_path / "audit.jsonl"), "utf-8")
    env = {**os.environ, "XDG_DATA_HOME": str(tmp_path)}
    gateway = Path(sys.executable).parent / "rc233-gateway"
    port = _free_port()
    process = await asyncio.create_subprocess_exec(
        str(gateway), "serve", "--simulate", "--config", str(path), "--port", str(port),
        "--time-scale", "20",
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE, env=env,
    )  # fmt: skip
    assert process.stderr is not None
    lines: list[str] = []
    try:
        # Not "Application startup complete": uvicorn says that before it binds the port.
        while not any("Uvicorn running on" in line for line in lines):
            line = await asyncio.wait_for(process.stderr.readline(), WAIT)
            assert line, "".join(lines)
            lines.append(line.decode())
        base = f"http://127.0.0.1:{port}/api/v1"
        async with httpx.AsyncClient(base_url=base, timeout=WAIT) as client:
            assert (await client.get("/axes")).status_code == 401
            reply = await client.get("/axes", headers={"Authorization": f"Bearer {VIEWER}"})
            assert reply.status_code == 200
            names = [(a["id"], a["name"]) for a in reply.json()]
            assert names == [("cell.4.1", "ram"), ("cell.4.2", None)]
            stop = await client.post(
                f"/axes/ram/stop?token={OPERATOR}",
                headers={"Authorization": f"Bearer {OPERATOR}", "Content-Type": "application/json"},
            )
            assert stop.status_code == 200, stop.text
        ws_url = f"ws://127.0.0.1:{port}/api/v1/ws?token={VIEWER}"
        async with connect(ws_url, open_timeout=WAIT) as ws:
            await ws.send(json.dumps({"type": "ping", "id": "1"}))
            assert json.loads(await asyncio.wait_for(ws.recv(), WAIT))["type"] == "pong"
    finally:
        process.send_signal(signal.SIGINT)
        rest = await asyncio.wait_for(process.stderr.read(), WAIT)
        assert await asyncio.wait_for(process.wait(), WAIT) == 0
    log = "".join(lines) + rest.decode()
    # The lines are there, masked (whatever the log's format: plain or JSON)
    assert 'WebSocket /api/v1/ws" [accepted]' in log, log  # uvicorn's line keeps no query
    assert "/axes/ram/stop?token=***" in log, log
    assert VIEWER not in log and OPERATOR not in log, log
    audit = (tmp_path / "audit.jsonl").read_text("utf-8")
    assert '"token":"mes"' in audit and OPERATOR not in audit
