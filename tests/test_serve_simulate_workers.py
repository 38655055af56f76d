"""``rc233-gateway serve --simulate`` runs its loop through a line worker, as ``serve --config``
does: the simulator lives in the worker (``gateway.cli.simulated_worker``), a child process of
``serve``; killed, the worker is started again with a fresh simulator, and meanwhile the loop
is down with the cause. The ``--control`` port, bound once by ``serve``, drives the simulator
of whichever worker runs, and a baud change reaches the simulated line through the worker.

Real processes (``tests/support/serve_process.py``); the worker is found from ``serve``'s
start line.
"""

from __future__ import annotations

import asyncio
import os
import re
import signal
import socket
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import httpx
import pytest

from gateway.cli import main
from tests.support.restart_rig import GATEWAY, RestartRig
from tests.support.serve_process import Served, free_port, serve
from tests.support.ws_events import Events, is_link, sim_control, worker_sample, ws_events

#: Real seconds to wait for an answer or an event.
WAIT = 30.0
API = "/api/v1"


@asynccontextmanager
async def _simulated(tmp_path: Path) -> AsyncIterator[tuple[Served, int, httpx.AsyncClient]]:
    """``serve --simulate`` (controllers 1, 2, 3; time x25) with its control surface on a
    free port, and an HTTP client; the loop is up."""
    control = free_port()
    options = ("--simulate", "--no-auth", "--time-scale", "25",
               "--control", f"127.0.0.1:{control}")  # fmt: skip
    async with (
        serve(tmp_path, *options) as served,
        httpx.AsyncClient(base_url=served.url, timeout=WAIT) as client,
    ):
        yield served, control, client


def _worker_pid(served: Served, loop: str) -> int:
    """The pid of the latest worker running ``loop``: a child of ``serve`` running the
    simulated worker program."""
    lines = [line for line in served.log if f"for the loops {loop}" in line]
    assert lines, "".join(served.log)
    found = re.search(r"line worker \S+ started \(pid (\d+)\)", lines[-1])
    assert found, lines
    pid = int(found[1])
    with open(f"/proc/{pid}/stat", encoding="ascii") as stat:
        parent = int(stat.read().rsplit(")", 1)[1].split()[1])
    assert parent == served.pid  # a child of serve, not some other process
    with open(f"/proc/{pid}/cmdline", "rb") as cmdline:
        assert b"gateway.cli.simulated_worker" in cmdline.read().split(b"\0")
    return pid


def _axis(event: dict[str, Any], axis: str, check: Callable[[dict[str, Any]], bool]) -> bool:
    data = event.get("data") or {}
    return data.get("id") == axis and data.get("stale") is False and check(data)


async def _kill_worker(served: Served, events: Events) -> int:
    """SIGKILL the loop's worker; returns once the new one's loop is up (its pid)."""
    first = _worker_pid(served, "sim")
    events.seen.clear()
    os.kill(first, signal.SIGKILL)
    down = await events.until(lambda e: is_link(e, "sim", False, "killed by SIGKILL"))
    assert "line worker sim was killed by SIGKILL; restarting in" in down["data"]["cause"]
    assert down["data"]["retry_after"] > 0
    await events.until(lambda e: is_link(e, "sim", True))
    second = _worker_pid(served, "sim")
    assert second != first
    return second


async def test_the_simulated_loop_runs_in_a_worker_that_is_restarted_when_killed(
    tmp_path: Path,
) -> None:
    async with _simulated(tmp_path) as (served, control, client), ws_events(served.url) as events:
        worker = _worker_pid(served, "sim")
        metrics = (await client.get("/metrics")).text
        assert worker_sample(metrics, "rc233_worker_up", "sim") == 1
        assert worker_sample(metrics, "rc233_worker_restarts_total", "sim") == 0
        assert f'rc233_process_resident_bytes{{role="worker",pid="{worker}"}}' in metrics

        moved = await client.post(
            f"{API}/axes/x/move?wait=true", json={"position": 3, "unit": "user"}
        )
        assert moved.status_code == 200 and moved.json()["state"] == "done", moved.text
        read = await client.get(f"{API}/axes/x")
        assert read.json()["position"] == 300 and read.json()["position_user"] == 3.0
        # what the simulator in the worker heard, through the control port
        assert (await sim_control(control, op="state"))["state"]["units"][0]["controller"]["axes"][
            "1"
        ]["position"] == 300

        await _kill_worker(served, events)
        metrics = (await client.get("/metrics")).text
        assert worker_sample(metrics, "rc233_worker_up", "sim") == 1
        assert worker_sample(metrics, "rc233_worker_restarts_total", "sim") == 1
        assert (await client.get("/readyz")).status_code == 200
        # The new worker built its simulator afresh: its axes at 0, as after a power-on.
        await events.until(lambda e: _axis(e, "sim.1.1", lambda d: d["position"] == 0))
        assert (await client.get(f"{API}/axes/x")).json()["position"] == 0
        moved = await client.post(
            f"{API}/axes/x/move?wait=true", json={"position": 1, "unit": "user"}
        )
        assert moved.status_code == 200 and moved.json()["state"] == "done", moved.text
        assert (await client.get(f"{API}/axes/x")).json()["position"] == 100
    assert any("line worker sim was killed by SIGKILL" in line for line in served.log)


async def test_the_control_port_drives_the_simulator_of_the_running_worker(
    tmp_path: Path,
) -> None:
    async with _simulated(tmp_path) as (served, control, client), ws_events(served.url) as events:
        await sim_control(control, op="ems", body="1", pressed=True)
        await events.until(lambda e: _axis(e, "sim.1.1", lambda d: d["errors"]["emergency"]))
        await sim_control(control, op="ems", body="1", pressed=False)

        await _kill_worker(served, events)
        # The same port, now served by the new worker: its simulator obeys and the gateway
        # sees it.
        await sim_control(control, op="preset", body="2", motor=1, position=1234)
        seen = await events.until(lambda e: _axis(e, "sim.2.1", lambda d: d["position"] == 1234))
        assert seen["data"]["name"] == "z"
        assert (await client.get(f"{API}/axes/z")).json()["position"] == 1234
        await sim_control(control, op="ems", body="3", pressed=True)
        await events.until(lambda e: _axis(e, "sim.3.1", lambda d: d["errors"]["emergency"]))


async def test_a_baud_change_reaches_the_simulated_line_through_the_worker(
    tmp_path: Path,
) -> None:
    async with _simulated(tmp_path) as (served, control, client):
        changed = await client.post(f"{API}/loops/sim/baud", json={"baud": 1200})
        assert changed.status_code == 200, changed.text
        body = changed.json()
        assert body["outcome"] == "done" and body["baud"] == 1200, body
        state = (await sim_control(control, op="state"))["state"]
        assert state["baud"] == 1200  # the host's UART: the simulated line in the worker
        assert [u["controller"]["baud"] for u in state["units"]] == [1200, 1200, 1200]
        assert (await client.get(f"{API}/loops/sim")).json()["baud"] == 1200
        moved = await client.post(
            f"{API}/axes/x/move?wait=true", json={"position": 2, "unit": "user"}
        )
        assert moved.status_code == 200 and moved.json()["state"] == "done", moved.text

        back = await client.post(f"{API}/loops/sim/baud", json={"baud": 9600})
        assert back.status_code == 200 and back.json()["outcome"] == "done", back.text
        state = (await sim_control(control, op="state"))["state"]
        assert state["baud"] == 9600
        assert [u["controller"]["baud"] for u in state["units"]] == [9600, 9600, 9600]
        assert _worker_pid(served, "sim")


def test_a_control_port_in_use_stops_serve_naming_the_option(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        argv = ["serve", "--simulate", "--no-auth", "--port", str(free_port()),
                "--eeprom-dir", str(tmp_path), "--control", f"127.0.0.1:{port}"]  # fmt: skip
        assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"--control 127.0.0.1:{port}: cannot listen there (Address already in use)" in err


async def test_a_ctrl_c_to_the_process_group_stops_serve_and_its_workers_cleanly(
    tmp_path: Path,
) -> None:
    """A terminal's Ctrl+C reaches every process of its foreground group (systemd's stop,
    every process of the unit): the workers leave the stop to ``serve``, which drains them;
    no worker dies of the signal on its own."""
    rig = RestartRig(tmp_path, 25.0)
    await rig.start_sim()
    try:
        process = await asyncio.create_subprocess_exec(
            str(GATEWAY), "serve", "--config", str(rig.config), "--no-auth",
            "--port", str(free_port()), "--time-scale", "25",
            stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE, env=rig.env,
            start_new_session=True,  # its own group, as a shell's foreground job
        )  # fmt: skip
        assert process.stderr is not None
        log: list[str] = []
        async with asyncio.timeout(WAIT):
            async for raw in process.stderr:
                log.append(raw.decode(errors="replace"))
                if "loop main up" in log[-1]:
                    break
        os.killpg(process.pid, signal.SIGINT)
        async with asyncio.timeout(WAIT):
            log += [raw.decode(errors="replace") async for raw in process.stderr]
            code = await process.wait()
        text = "".join(log)
        assert code == 0, text
        assert "line worker main started" in text
        assert "Traceback" not in text and "killed by SIGINT" not in text, text
    finally:
        await rig.close()
