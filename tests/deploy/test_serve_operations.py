"""`rc233-gateway serve` as systemd runs it: readiness on $NOTIFY_SOCKET, JSON log lines.

The unit (deploy/systemd) is `Type=notify` with `--log-format json`: the service must say
READY=1 once it serves HTTP and STOPPING=1 when it stops, and every line it writes must be
one JSON object, the state changes carrying their loop and controller.
"""

from __future__ import annotations

import asyncio
import json
import socket
from pathlib import Path

import httpx

from gateway import __version__
from gateway.cli import main
from tests.support.serve_process import TIME_SCALE, serve


def test_version(capsys: object) -> None:
    try:
        main(["--version"])
    except SystemExit as exit_:
        assert exit_.code == 0
    out = capsys.readouterr().out  # type: ignore[attr-defined]
    assert out == f"rc233-gateway {__version__}\n"


async def test_ready_on_the_notify_socket_and_json_lines(tmp_path: Path) -> None:
    path = tmp_path / "notify"
    receiver = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    receiver.bind(str(path))
    receiver.setblocking(False)
    loop = asyncio.get_running_loop()
    options = ("--simulate", "--no-auth", "--time-scale", str(TIME_SCALE), "--log-format", "json")
    try:
        async with serve(tmp_path, *options, env={"NOTIFY_SOCKET": str(path)}) as server:
            ready = await asyncio.wait_for(loop.sock_recv(receiver, 4096), 10)
            assert ready == b"READY=1"
            async with httpx.AsyncClient(base_url=server.url) as client:
                assert (await client.get("/healthz")).status_code == 200
        stopping = await asyncio.wait_for(loop.sock_recv(receiver, 4096), 10)
        assert stopping == b"STOPPING=1"
    finally:
        receiver.close()
    lines = [json.loads(line) for line in server.log]  # every line is JSON
    assert all({"time", "level", "logger", "message"} <= set(line) for line in lines)
    up = [line for line in lines if line.get("event") == "loop_up"]
    assert [(u["loop"], u["message"]) for u in up] == [("sim", "loop sim up")]
    online = sorted(e["controller"] for e in lines if e.get("event") == "controller_online")
    assert online == ["sim.1", "sim.2", "sim.3"]
    assert any("AUTHENTICATION IS OFF" in line["message"] for line in lines)
    assert any(line["logger"].startswith("uvicorn") for line in lines)
