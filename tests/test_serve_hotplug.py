"""One unplugged adapter is one loop down: ``serve --config`` starts, and plugging it in
brings the loop up.

Real processes, as on a site: ``rc233-gateway serve`` on a file with two loops, one on a
``sim --pty`` that is there, one on a device path that does not exist yet (a USB adapter not
plugged in at boot). The working loop serves; the other is down with that cause in
``GET /loops`` and the metrics. Then the device appears (a second ``sim --pty`` and a link at
the configured path, as udev makes ``/dev/serial/by-id/...``) and the loop comes up, waited on
through the WebSocket feed, never by sleeping.
"""

from __future__ import annotations

import asyncio
import json
from pathlib import Path
from typing import Any

import httpx
from websockets.asyncio.client import ClientConnection, connect

from tests.support.serve_process import serve
from tests.support.sim_process import sim_on_pty

SCALE = "20"
WAIT = 30.0
CELL = """
[[loops]]
name = "there"
port = "{there}"
[[loops.controllers]]
body = "1"

[[loops]]
name = "later"
port = "{later}"
[[loops.controllers]]
body = "2"
"""


class LoopFeed:
    """The loops' views as the WebSocket feed last sent them (snapshot, then changes)."""

    def __init__(self, ws: ClientConnection) -> None:
        self.ws = ws
        self.latest: dict[str, dict[str, Any]] = {}

    async def until(self, loop: str, wanted: dict[str, Any]) -> dict[str, Any]:
        """The view of ``loop`` once it has ``wanted`` (reading the feed until then)."""
        async with asyncio.timeout(WAIT):
            while not wanted.items() <= self.latest.get(loop, {}).items():
                message = json.loads(await self.ws.recv())
                views = message.get("loops", [])
                if message.get("type") == "change" and message["topic"].startswith("loop:"):
                    views = [message["data"]]
                self.latest |= {view["name"]: view for view in views}
        return self.latest[loop]


def _metric(text: str, sample: str) -> float:
    line = next(x for x in text.splitlines() if x.startswith(sample + " "))
    return float(line.split()[-1])


async def test_a_loop_whose_device_is_missing_starts_down_and_comes_up_when_it_appears(
    tmp_path: Path,
) -> None:
    later = tmp_path / "dev" / "serial" / "by-id" / "usb-adapter-port0"
    async with sim_on_pty(tmp_path / "one", "--bodies", "1", "--time-scale", SCALE) as there:
        cell = tmp_path / "cell.toml"
        cell.write_text(CELL.format(there=there, later=later), "utf-8")
        # Before: refused to start (`loops[1].port: ... No such file or directory`, exit 2).
        async with serve(tmp_path, "--config", str(cell), "--no-auth") as served:
            assert any("loops[1].port" in line and "does not exist yet" in line
                       for line in served.log), "".join(served.log)  # fmt: skip
            ws_url = f"ws://127.0.0.1:{served.port}/api/v1/ws"
            async with (
                httpx.AsyncClient(base_url=served.url, timeout=WAIT) as client,
                connect(ws_url, open_timeout=WAIT) as ws,
            ):
                await ws.send(json.dumps({"type": "subscribe", "topics": ["loop:*"]}))
                feed = LoopFeed(ws)
                await feed.until("there", {"up": True})
                down = await feed.until("later", {"up": False})
                assert "the device is not present (No such file or directory)" in down["cause"]
                assert str(later) in down["cause"]
                # The loop that is there serves: a fresh read through its line.
                read = await client.get("/api/v1/controllers/there.1/io")
                assert read.status_code == 200, read.text
                refused = await client.get("/api/v1/controllers/later.2/io")
                assert refused.status_code == 503, refused.text
                metrics = (await client.get("/metrics")).text
                assert _metric(metrics, 'rc233_loop_up{loop="there"}') == 1
                assert _metric(metrics, 'rc233_loop_up{loop="later"}') == 0

                # The adapter is plugged in: udev makes its link, the gateway opens it.
                async with sim_on_pty(
                    tmp_path / "two", "--bodies", "2", "--time-scale", SCALE
                ) as device:
                    later.parent.mkdir(parents=True)
                    later.symlink_to(device)
                    await feed.until("later", {"up": True, "cause": None})
                    loops = {v["name"]: v for v in (await client.get("/api/v1/loops")).json()}
                    assert loops["later"]["up"] and loops["later"]["cause"] is None
                    assert loops["later"]["counters"]["link_downs"] == 1
                    read = await client.get("/api/v1/controllers/later.2/io")
                    assert read.status_code == 200, read.text
                    metrics = (await client.get("/metrics")).text
                    assert _metric(metrics, 'rc233_loop_up{loop="later"}') == 1
