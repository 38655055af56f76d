"""deploy/ser2net/*.yaml in front of `rc233-gateway sim --pty`, the gateway over TCP.

Debian's ser2net 4 runs the deploy files as shipped, with only the device path (the
simulator's pseudo-terminal) and the listening address changed; the gateway reaches the loop
through `socket://` (raw TCP) and `rfc2217://...?ign_set_control` and homes and moves an axis.
"""

from __future__ import annotations

import asyncio
import re
import shutil
import signal
from collections.abc import AsyncIterator
from pathlib import Path

import httpx
import pytest

from gateway.api.app import create_app
from gateway.api.security import AuthConfig
from gateway.cli.serve import open_lines
from gateway.compose import compose
from gateway.service.config import load_config
from gateway.service.runtime import Runtime
from tests.support.serve_process import free_port
from tests.support.sim_process import sim_on_pty

DEPLOY = Path(__file__).parents[2] / "deploy" / "ser2net"
SCALE = 20.0
CELL = """
[[loops]]
name = "line"
port = "{url}"
[loops.timeouts]
# A device server adds its own latency (and this machine is busy with other tests).
host_latency = 0.25
[loops.poll]
idle_period = 0.5
[[loops.controllers]]
body = "1"
[[loops.controllers.axes]]
motor = 1
name = "x"
"""
MODES = {
    "ser2net-raw.yaml": ("tcp,4001", "socket://127.0.0.1:{port}"),
    "ser2net-rfc2217.yaml": ("tcp,4002", "rfc2217://127.0.0.1:{port}?ign_set_control"),
}


def _ser2net() -> str:
    found = shutil.which("ser2net") or shutil.which("ser2net", path="/usr/sbin:/sbin")
    assert found, "ser2net is not installed: `apt-get install ser2net` (`make test` does it)"
    return found


async def _wait_listening(port: int, process: asyncio.subprocess.Process) -> None:
    """Until ser2net accepts connections on ``port`` (it prints nothing when it is ready)."""
    async with asyncio.timeout(10):
        while True:
            assert process.returncode is None, "ser2net stopped"
            try:
                _, writer = await asyncio.open_connection("127.0.0.1", port)
            except OSError:
                await asyncio.sleep(0.05)
                continue
            writer.close()
            await writer.wait_closed()
            return


@pytest.fixture(params=sorted(MODES))
async def client(
    request: pytest.FixtureRequest, tmp_path: Path
) -> AsyncIterator[httpx.AsyncClient]:
    name: str = request.param
    accepter, url = MODES[name]
    binary = _ser2net()
    port = free_port()
    text = (DEPLOY / name).read_text()
    assert "chardelay: false" in text and "/dev/rc233-loop1" in text and accepter in text
    async with sim_on_pty(tmp_path, "--bodies", "1", "--time-scale", str(SCALE)) as pty:
        config = tmp_path / name
        config.write_text(
            text.replace("/dev/rc233-loop1", pty).replace(accepter, f"tcp,127.0.0.1,{port}")
        )
        ser2net = await asyncio.create_subprocess_exec(
            binary, "-n", "-c", str(config), "-P", str(tmp_path / "ser2net.pid"),
            stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.DEVNULL,
        )  # fmt: skip
        try:
            await _wait_listening(port, ser2net)
            cell = tmp_path / "cell.toml"
            cell.write_text(CELL.format(url=url.format(port=port)))
            config = load_config(cell)
            gateway = Runtime(config, transports=open_lines(config), time_scale=SCALE)
            app = create_app(compose(gateway), auth=AuthConfig(no_auth=True))
            async with app.router.lifespan_context(app):
                transport = httpx.ASGITransport(app=app)
                base = "http://localhost/api/v1"
                async with httpx.AsyncClient(transport=transport, base_url=base, timeout=30) as c:
                    yield c
        finally:
            ser2net.send_signal(signal.SIGTERM)
            await asyncio.wait_for(ser2net.wait(), 10)


async def test_home_and_move_through_ser2net(client: httpx.AsyncClient) -> None:
    loop = (await client.get("/loops/line")).json()
    assert re.match(r"(socket|rfc2217)://127\.0\.0\.1:\d+", loop["port"]), loop
    home = await client.post("/axes/x/home?wait=true&timeout=30", json={"method": "0"})
    assert home.status_code == 200, home.text
    assert home.json()["state"] == "done"
    move = await client.post(
        "/axes/x/move?wait=true&timeout=30", json={"position": 4000, "unit": "pulse"}
    )
    assert move.status_code == 200, move.text
    assert move.json()["state"] == "done", move.json()
    fresh = (await client.get("/axes/x?fresh=true")).json()
    assert fresh["position"] == 4000
    assert (await client.get("/loops/line")).json()["up"] is True
