"""``serve --config`` on a loop at ``socket://``: the way a site reaches a serial device server
(ser2net, Moxa), here ``rc233-gateway sim --tcp``. serve runs on uvloop where it is installed,
whose transports take no new attributes: the socket line must open there all the same."""

from __future__ import annotations

import asyncio
import os
import re
import signal
import time
from pathlib import Path

import httpx

from tests.support.serve_process import GATEWAY, serve

CELL = """
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


async def test_a_loop_on_a_device_server_answers_through_serve(tmp_path: Path) -> None:
    sim = await asyncio.create_subprocess_exec(
        str(GATEWAY), "sim", "--tcp", "127.0.0.1:0", "--eeprom-dir", str(tmp_path / "sim"),
        "--time-scale", "10", stdout=asyncio.subprocess.PIPE,
        env={**os.environ, "XDG_DATA_HOME": str(tmp_path)},
    )  # fmt: skip
    assert sim.stdout is not None
    try:
        line = (await asyncio.wait_for(sim.stdout.readline(), 20)).decode()
        found = re.search(r"socket://127\.0\.0\.1:(\d+)", line)
        assert found, line
        cell = tmp_path / "cell.toml"
        cell.write_text(CELL.format(port=found.group(1)))
        async with serve(tmp_path, "--config", str(cell), "--no-auth") as gateway:
            url = f"{gateway.url}/api/v1/axes/x?fresh=true"
            deadline = time.monotonic() + 30
            async with httpx.AsyncClient(timeout=10) as client:
                while True:  # 503 while the loop opens; then read from the line
                    answer = await client.get(url)
                    if answer.status_code != 503 or time.monotonic() > deadline:
                        break
                    await asyncio.sleep(0.1)
            assert answer.status_code == 200, "".join(gateway.log) + answer.text
            assert answer.json()["position"] == 0
            assert not [x for x in gateway.log if "cannot open" in x], gateway.log
    finally:
        sim.send_signal(signal.SIGTERM)
        assert await asyncio.wait_for(sim.wait(), 20) == 0
