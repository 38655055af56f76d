"""A cell whose gateway is killed and started again: ``rc233-gateway sim --tcp`` (with its
control surface) outlives ``rc233-gateway serve`` processes started on one configuration with
one state directory, the way a site restarts its gateway while the machine goes on.

``RestartRig.serve()`` starts a gateway and waits until its loop is up; ``kill()`` SIGKILLs
it, ``stop()`` SIGTERMs it (exit code 0 expected); ``heard(frame)`` counts the frames the
simulated loop heard, over every gateway process; ``events()`` follows the operation events
of the running gateway over its WebSocket (woken by each message, no sleeping).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import re
import signal
import socket
import sqlite3
import sys
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from websockets.asyncio.client import ClientConnection, connect

from gateway.service.store.database import DATABASE_NAME
from tests.support.ws_events import sim_control

GATEWAY = Path(sys.executable).parent / "rc233-gateway"
#: Real seconds to wait for a process or an answer.
WAIT = 30.0

CELL = """
state_dir = "{state}"

[[loops]]
name = "main"
port = "socket://127.0.0.1:{port}"

[[loops.controllers]]
body = "1"
name = "stage"
[[loops.controllers.axes]]
motor = 1
name = "x"
"""


@dataclass
class Gateway:
    """One ``serve`` process: its API's base URL and what it wrote to stderr."""

    process: asyncio.subprocess.Process
    url: str
    log: list[str] = field(default_factory=list)
    reader: asyncio.Task[None] | None = None


class RestartRig:
    """The simulator (a process for the whole test) and the gateways started on it."""

    def __init__(self, tmp_path: Path, time_scale: float) -> None:
        self.tmp_path = tmp_path
        self.time_scale = time_scale
        self.env = {**os.environ, "XDG_DATA_HOME": str(tmp_path)}
        self.sim: asyncio.subprocess.Process | None = None
        self.control_port = _free_port()
        self.config = tmp_path / "cell.toml"
        self.state_dir = tmp_path / "state"
        self.gateway: Gateway | None = None

    async def start_sim(self) -> None:
        """``sim --tcp`` on a free port, its control surface on another."""
        self.sim = await asyncio.create_subprocess_exec(
            str(GATEWAY), "sim", "--tcp", "127.0.0.1:0", "--eeprom-dir", str(self.tmp_path / "sim"),
            "--time-scale", str(self.time_scale), "--control", f"127.0.0.1:{self.control_port}",
            stdout=asyncio.subprocess.PIPE, env=self.env,
        )  # fmt: skip
        assert self.sim.stdout is not None
        line = (await asyncio.wait_for(self.sim.stdout.readline(), WAIT)).decode()
        found = re.search(r"socket://127\.0\.0\.1:(\d+)", line)
        assert found, line
        self.config.write_text(CELL.format(state=self.state_dir, port=found.group(1)), "utf-8")

    async def close(self) -> None:
        """Stop the gateway left running, then the simulator (exit code 0 each)."""
        if self.gateway is not None and self.gateway.process.returncode is None:
            await self.stop()
        if self.sim is not None:
            self.sim.send_signal(signal.SIGTERM)
            assert await asyncio.wait_for(self.sim.wait(), WAIT) == 0

    # ------------------------------------------------------------------ gateways

    async def serve(self) -> Gateway:
        """A new ``serve --config`` process, once its loop is up (``/readyz`` 200)."""
        port = _free_port()
        process = await asyncio.create_subprocess_exec(
            str(GATEWAY), "serve", "--config", str(self.config), "--no-auth",
            "--port", str(port), "--time-scale", str(self.time_scale),
            stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE, env=self.env,
        )  # fmt: skip
        gateway = Gateway(process, f"http://127.0.0.1:{port}")
        up, bound = asyncio.Event(), asyncio.Event()

        async def read_log() -> None:
            assert process.stderr is not None
            async for raw in process.stderr:
                line = raw.decode(errors="replace")
                gateway.log.append(line)
                if "loop main up" in line:
                    up.set()
                # Not "Application startup complete": uvicorn says that before it binds.
                if "Uvicorn running on" in line:
                    bound.set()
            up.set()  # the process ended: the check below says so
            bound.set()

        gateway.reader = asyncio.create_task(read_log())
        await asyncio.wait_for(asyncio.gather(up.wait(), bound.wait()), WAIT)
        assert process.returncode is None, "".join(gateway.log)
        self.gateway = gateway
        return gateway

    def kill(self) -> None:
        """SIGKILL the gateway: nothing of it runs after this (no shutdown, no flush)."""
        assert self.gateway is not None
        self.gateway.process.kill()

    async def wait_killed(self) -> None:
        """Until the killed gateway's process is gone."""
        assert self.gateway is not None
        await asyncio.wait_for(self.gateway.process.wait(), WAIT)

    async def stop(self) -> None:
        """SIGTERM: the gateway shuts down cleanly, exit code 0."""
        assert self.gateway is not None
        self.gateway.process.send_signal(signal.SIGTERM)
        code = await asyncio.wait_for(self.gateway.process.wait(), WAIT)
        assert code == 0, "".join(self.gateway.log)

    # ------------------------------------------------------------------ the simulator

    async def stored(self, op_id: str, state: str) -> None:
        """Wait until the state store on disk holds operation ``op_id`` in ``state``: the
        gateway queues its saves after it publishes a change, so an event a client saw can be
        ahead of the record a restart reads (read through SQLite's WAL, as a new process
        would)."""

        def read() -> str | None:
            path = self.state_dir / DATABASE_NAME
            if not path.exists():
                return None
            with contextlib.closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as db:
                row = db.execute("SELECT state FROM operations WHERE id = ?", (op_id,)).fetchone()
            return None if row is None else str(row[0])

        async def until_stored() -> None:
            while await asyncio.to_thread(read) != state:
                await asyncio.sleep(0.02)  # a file another process writes: no event to wait on

        await asyncio.wait_for(until_stored(), WAIT)

    async def control(self, **request: Any) -> dict[str, Any]:
        """One request to the simulator's control surface."""
        return await sim_control(self.control_port, **request)

    async def axis(self, body: str, motor: int) -> dict[str, Any]:
        """The simulated axis as the simulator knows it (position, moving)."""
        units = (await self.control(op="state"))["state"]["units"]
        found = [u["controller"] for u in units if u["name"] == body and u["controller"]]
        assert found, units
        axis: dict[str, Any] = found[0]["axes"][str(motor)]
        return axis

    async def heard(self, frame: str) -> int:
        """How many times the loop heard ``frame`` (e.g. ``$1A3000``), over every gateway."""
        records = (await self.control(op="trace"))["trace"]
        return sum(1 for r in records if r["kind"] == "heard" and r["data"] == frame + "\r")

    # ------------------------------------------------------------------ events

    @asynccontextmanager
    async def events(self) -> AsyncIterator[Callable[..., Any]]:
        """Subscribe to the running gateway's operation events; yields ``until(check)``,
        which returns the first operation (the event's data) for which ``check`` holds."""
        assert self.gateway is not None
        ws_url = self.gateway.url.replace("http", "ws", 1) + "/api/v1/ws"
        async with connect(ws_url, open_timeout=WAIT) as ws:
            await ws.send(json.dumps({"type": "subscribe", "topics": ["event:operation"]}))

            async def until(check: Callable[[dict[str, Any]], bool]) -> dict[str, Any]:
                return await _until(ws, check)

            yield until


async def _until(ws: ClientConnection, check: Callable[[dict[str, Any]], bool]) -> dict[str, Any]:
    async with asyncio.timeout(WAIT):
        while True:
            message = json.loads(await ws.recv())
            if message.get("type") == "event" and check(message["data"]):
                data: dict[str, Any] = message["data"]
                return data


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])
