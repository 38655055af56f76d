"""The API on a loop served by `rc233-gateway sim --pty`, reached through a config file.

The same path a real site uses: a TOML file names the loop's device path, the gateway opens
it with pyserial-asyncio (``SerialLine``), and the simulator is a separate process behind a
pseudo-terminal. A user's first calls: list the axes, home, move, read back, any command.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import httpx
import pytest

from gateway.api.app import create_app
from gateway.api.security import AuthConfig
from gateway.cli.serve import open_lines
from gateway.compose import compose
from gateway.service.config import load_config
from gateway.service.runtime.runtime import Runtime
from tests.support.sim_process import sim_on_pty

SCALE = 20.0
CELL = """
[[loops]]
name = "bench"
port = "{port}"
[loops.poll]
idle_period = 0.5

[[loops.controllers]]
body = "1"
name = "stage"
[[loops.controllers.axes]]
motor = 1
name = "x"
unit = "mm"
units_per_pulse = 0.01
soft_min = -10.0
soft_max = 500.0
"""


@pytest.fixture
async def client(tmp_path: Path) -> AsyncIterator[httpx.AsyncClient]:
    async with sim_on_pty(tmp_path, "--bodies", "1", "--time-scale", str(SCALE)) as port:
        cell = tmp_path / "cell.toml"
        cell.write_text(CELL.format(port=port))
        config = load_config(cell)
        gateway = Runtime(config, transports=open_lines(config), time_scale=SCALE)
        app = create_app(compose(gateway), auth=AuthConfig(no_auth=True))
        async with app.router.lifespan_context(app):
            transport = httpx.ASGITransport(app=app)
            base = "http://localhost/api/v1"
            async with httpx.AsyncClient(transport=transport, base_url=base, timeout=30) as c:
                yield c


async def test_first_calls_through_a_pseudo_terminal(client: httpx.AsyncClient) -> None:
    axes = (await client.get("/axes")).json()
    assert [(a["id"], a["name"], a["unit"]) for a in axes] == [
        ("bench.1.1", "x", "mm"),
        ("bench.1.2", None, "pulse"),
    ]
    home = await client.post("/axes/x/home?wait=true&timeout=30", json={"method": "0"})
    assert home.status_code == 200, home.text
    assert home.json()["state"] == "done"
    move = await client.post(
        "/axes/x/move?wait=true&timeout=30", json={"position": 12.5, "unit": "user"}
    )
    assert move.status_code == 200, move.text
    assert move.json()["state"] == "done"
    fresh = (await client.get("/axes/x?fresh=true")).json()
    assert (fresh["position"], fresh["position_user"]) == (1250, 12.5)
    # Outside the soft limits: refused, naming the field and the rule.
    refused = await client.post("/axes/x/move", json={"position": 600, "unit": "user"})
    assert refused.status_code == 422
    assert refused.json()["field"] == "body.position"
    assert "soft limits [-10, 500] mm" in refused.json()["rule"]
    # Any command of the catalog, typed: OH read back with its §16 default.
    oh = await client.post("/controllers/stage/commands", json={"command": "OH"})
    assert oh.status_code == 200, oh.text
    assert "5000" in oh.text
