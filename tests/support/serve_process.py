"""``rc233-gateway serve`` as a separate process, the way an integrator runs it.

For the tests of the integrator's documents and the examples: a client generated from
openapi.json, the MES example and the AsyncAPI checks talk to a real server over TCP.
The server's stderr is read all along (a full pipe would stall it) and kept for messages.
"""

from __future__ import annotations

import asyncio
import os
import resource
import signal
import socket
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path

GATEWAY = Path(sys.executable).parent / "rc233-gateway"
#: Homing takes about 25 s at real time; at this scale about a second.
TIME_SCALE = 25.0


def free_port() -> int:
    """A TCP port nobody listens on now."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@dataclass
class Served:
    """A running server: its base URL and the lines it wrote to stderr so far."""

    url: str
    port: int
    pid: int = 0
    log: list[str] = field(default_factory=list)


def _limit_files(soft: int) -> None:
    hard = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
    resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))


@asynccontextmanager
async def serve(
    tmp_path: Path, *options: str, env: dict[str, str] | None = None, files: int | None = None
) -> AsyncIterator[Served]:
    """Start ``rc233-gateway serve`` with ``options`` (default ``--simulate`` at
    ``TIME_SCALE``) on a free port; after the block SIGINT must end it with exit code 0.
    ``files``: the process's soft descriptor limit (systemd's default is 1,024)."""
    port = free_port()
    argv = options or ("--simulate", "--no-auth", "--time-scale", str(TIME_SCALE))
    # XDG_STATE_HOME: a real line's default state directory is the test's own, never the user's
    env = {**os.environ, "XDG_DATA_HOME": str(tmp_path), "XDG_STATE_HOME": str(tmp_path),
           **(env or {})}  # fmt: skip
    if "--simulate" in argv and "--eeprom-dir" not in argv:
        argv = (*argv, "--eeprom-dir", str(tmp_path / "eeprom"))
    process = await asyncio.create_subprocess_exec(
        str(GATEWAY), "serve", *argv, "--port", str(port),
        stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE, env=env,
        preexec_fn=None if files is None else lambda: _limit_files(files),
    )  # fmt: skip
    assert process.stderr is not None
    served = Served(f"http://127.0.0.1:{port}", port, process.pid)
    started = asyncio.Event()

    async def read_log() -> None:
        assert process.stderr is not None
        async for raw in process.stderr:
            line = raw.decode(errors="replace")
            served.log.append(line)
            # Not "Application startup complete": uvicorn says that before it binds the port.
            if "Uvicorn running on" in line:
                started.set()
        started.set()  # the process ended: the wait below sees it

    reader = asyncio.create_task(read_log())
    try:
        await asyncio.wait_for(started.wait(), 30)
        assert process.returncode is None, "".join(served.log)
        yield served
    finally:
        if process.returncode is None:
            process.send_signal(signal.SIGINT)
        code = await asyncio.wait_for(process.wait(), 30)
        await asyncio.wait_for(reader, 5)
        assert code == 0, "".join(served.log)
