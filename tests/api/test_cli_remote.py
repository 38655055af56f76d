"""`rc233-gateway trace LOOP` and `rc233-gateway audit --follow` against a running gateway.

The commands run as separate processes, as a technician runs them at a terminal, against
the real app (on a simulated loop) served by uvicorn with tokens: the trace shows the frames
on the wire, the audit follows a move as it is made, and without a token both are refused.
"""

from __future__ import annotations

import asyncio
import os
import signal
import sys
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from gateway.cli import main
from tests.support.sim_app import TOKENS, Api, auth, running_app
from tests.support.ws_server import start_uvicorn

GATEWAY = Path(sys.executable).parent / "rc233-gateway"


@pytest.fixture
async def served() -> AsyncIterator[tuple[Api, str]]:
    async with running_app(roles=True) as api:
        server, port = await start_uvicorn(api.app)
        try:
            yield api, f"http://127.0.0.1:{port}"
        finally:
            server.should_exit = True
            await server.shutdown()


async def _start(*argv: str, token: str | None = TOKENS["admin"][0]) -> asyncio.subprocess.Process:
    env = {k: v for k, v in os.environ.items() if k != "RC233_TOKEN"}
    if token:
        env["RC233_TOKEN"] = token
    return await asyncio.create_subprocess_exec(
        str(GATEWAY), *argv, "--interval", "0.1",
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE, env=env,
    )  # fmt: skip


async def _read_until(process: asyncio.subprocess.Process, *needles: str) -> list[str]:
    """Lines of the process's output until one holds every one of ``needles``."""
    assert process.stdout is not None
    lines: list[str] = []
    async with asyncio.timeout(20):
        while not any(all(n in line for n in needles) for line in lines):
            raw = await process.stdout.readline()
            assert raw, "".join(lines) + (await process.stderr.read()).decode()  # type: ignore[union-attr]
            lines.append(raw.decode())
    return lines


async def _interrupt(process: asyncio.subprocess.Process) -> None:
    process.send_signal(signal.SIGINT)
    # Read both pipes to their end while it stops: a process blocked on a full pipe would
    # never reach its clean-up.
    await asyncio.wait_for(process.communicate(), 20)
    assert process.returncode == 0


async def test_trace_follows_the_frames_on_the_wire(served: tuple[Api, str]) -> None:
    api, url = served
    trace = await _start("trace", "sim", "--url", url)
    try:
        # The poller's status reads of controller 1 (the empty command), as sent.
        lines = await _read_until(trace, " tx ", "sim.1")
        assert any(line.rstrip().endswith("sim.1    $1\\r") for line in lines), lines
    finally:
        await _interrupt(trace)
    # It switched the trace on for itself, and off again when it ended.
    after = await api.client.get("/loops/sim/trace", headers=auth("admin"))
    assert after.json()["enabled"] is False


async def test_audit_follow_prints_a_move_as_it_is_made(served: tuple[Api, str]) -> None:
    api, url = served
    follow = await _start("audit", "--follow", "--url", url)
    try:
        move = await api.client.post(
            "/axes/x/move?wait=true", json={"position": 300, "unit": "pulse"},
            headers=auth("operator"),
        )  # fmt: skip
        assert move.status_code == 200, move.text
        lines = await _read_until(follow, "/api/v1/axes/x/move?wait=true -> 200")
        ahead, line = [ln for ln in lines if "/api/v1/axes/x/move" in ln]
        assert "-> ahead" in ahead  # its entry, written before anything was sent
        assert "operator  POST /api/v1/axes/x/move?wait=true -> 200" in line
        assert "sent $1" in line  # the frames that went out
    finally:
        await _interrupt(follow)


async def test_without_an_admin_token_both_are_refused(
    served: tuple[Api, str], capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """In a thread of this process (the server answers from the test's event loop)."""
    _, url = served
    monkeypatch.delenv("RC233_TOKEN", raising=False)
    code = await asyncio.to_thread(main, ["audit", "--url", url])
    assert code == 2
    assert "refused: GET /audit?limit=100: 401" in capsys.readouterr().err
    viewer = TOKENS["viewer"][0]
    argv = ["trace", "sim", "--once", "--url", url, "--token", viewer]
    code = await asyncio.to_thread(main, argv)
    assert code == 2
    assert "refused: GET /loops/sim/trace: 403" in capsys.readouterr().err
    code = await asyncio.to_thread(main, ["audit", "--url", "http://127.0.0.1:9", "--token", "x"])
    assert code == 3
    assert "cannot reach http://127.0.0.1:9" in capsys.readouterr().err
