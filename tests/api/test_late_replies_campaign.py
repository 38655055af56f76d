"""Late replies from outside: ``rc233-gateway sim --tcp`` and ``serve --config`` as processes,
20 % of the replies leaving 90 ms (device time) late, the simulator's control port arming the
fault (``{"op": "fault", "kind": "late", "probability": 0.2, "delay": 0.09}``).

Four concurrent readers ask for position table entries, speeds, axis positions read now and the
cached axis views; every entry, speed and position holds a distinct value written before the
faults, and nothing moves: every answer must be that value (the simulator's truth, read back
from its control port at the end). Answers that are errors (a read given up) are allowed and
counted; a wrong value never is. The figures are printed (``pytest -s``).

The simulator runs twice as fast as real time: a late reply then begins some 12 ms after its
time-out (the gateway's host margin is not scaled), and the line's resync after a time-out
waits for the silence of the loop's longest reply.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import random
import re
import signal
import time
from collections import Counter
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.support.serve_process import GATEWAY, free_port, serve

SCALE = 1.0
ANSWERS = 1000
READERS = 4
BODIES = ("1", "2")
ENTRIES = range(8)
CELL = """
[[loops]]
name = "main"
port = "socket://127.0.0.1:{port}"
{controllers}
"""
CONTROLLER = """
[[loops.controllers]]
body = "{body}"
name = "c{body}"
[[loops.controllers.axes]]
motor = 1
name = "a{body}1"
[[loops.controllers.axes]]
motor = 2
name = "a{body}2"
"""


def entry_value(body: str, n: int) -> int:
    return 100_000 * int(body) + 1_000 * (n + 1) + 7 * n


def axis_position(body: str, motor: int) -> int:
    return 11_111 * (2 * int(body) + motor)


def axis_speed(body: str, motor: int) -> dict[str, int]:
    k = 2 * int(body) + motor
    return {"oh": 3_000 + 101 * k, "ol": 300 + 11 * k, "os": 1_000 + 37 * k}


class Control:
    """The simulator's control port: one JSON object per line each way."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.reader, self.writer = reader, writer

    async def __call__(self, **request: Any) -> dict[str, Any]:
        self.writer.write(json.dumps(request).encode() + b"\n")
        await self.writer.drain()
        reply: dict[str, Any] = json.loads(await asyncio.wait_for(self.reader.readline(), 10))
        assert reply["ok"], reply
        return reply


@contextlib.asynccontextmanager
async def simulator(tmp_path: Path) -> AsyncIterator[tuple[str, Control]]:
    """``sim --tcp`` with a control port: its ``socket://`` URL and the control client."""
    sim = await asyncio.create_subprocess_exec(
        str(GATEWAY), "sim", "--tcp", "127.0.0.1:0", "--bodies", ",".join(BODIES),
        "--control", f"127.0.0.1:{free_port()}", "--eeprom-dir", str(tmp_path / "sim"),
        "--time-scale", str(SCALE), "--seed", "21", stdout=asyncio.subprocess.PIPE,
        env={**os.environ, "XDG_DATA_HOME": str(tmp_path)},
    )  # fmt: skip
    assert sim.stdout is not None
    writer: asyncio.StreamWriter | None = None
    try:
        line = (await asyncio.wait_for(sim.stdout.readline(), 20)).decode()
        found = re.search(r"(socket://\S+) .* control 127\.0\.0\.1:(\d+)", line)
        assert found, line
        reader, writer = await asyncio.open_connection("127.0.0.1", int(found.group(2)))
        yield found.group(1), Control(reader, writer)
    finally:
        if writer is not None:
            writer.close()
        sim.send_signal(signal.SIGTERM)
        assert await asyncio.wait_for(sim.wait(), 20) == 0


async def answered(client: httpx.AsyncClient, path: str) -> httpx.Response:
    """``path`` once the loop is up (503 while the line opens)."""
    deadline = time.monotonic() + 30
    while True:
        response = await client.get(path)
        if response.status_code != 503 or time.monotonic() > deadline:
            return response
        await asyncio.sleep(0.1)


async def write_truth(client: httpx.AsyncClient) -> None:
    """Distinct values everywhere, each checked by its own read-back (no faults yet)."""
    for body in BODIES:
        for n in ENTRIES:
            r = await client.put(
                f"/controllers/c{body}/positions/{n}", json={"position": entry_value(body, n)}
            )
            assert r.status_code == 200 and r.json()["outcome"] == "done", r.text
        for motor in (1, 2):
            r = await client.put(f"/axes/a{body}{motor}/speed", json=axis_speed(body, motor))
            assert r.status_code == 200, r.text
            r = await client.post(
                f"/controllers/c{body}/commands",
                params={"motor": motor},
                json={"command": "R{pp}", "pp": axis_position(body, motor)},
            )
            assert r.status_code == 200 and r.json()["outcome"] == "done", r.text


def check(kind: str, body: str, motor: int, n: int, answer: dict[str, Any]) -> list[str]:
    """What in ``answer`` is not the truth (empty: all right)."""
    wrong: list[str] = []
    if kind == "entry" and answer["position"] != entry_value(body, n):
        wrong.append(f"entry {body}/{n}: {answer['position']} not {entry_value(body, n)}")
    elif kind == "speed":
        truth = axis_speed(body, motor)
        got = {k: answer[k] for k in truth}
        if got != truth:
            wrong.append(f"speed a{body}{motor}: {got} not {truth}")
    elif kind in ("fresh", "cached"):
        position = answer["position"]
        if kind == "fresh" and position is None:
            wrong.append(f"fresh a{body}{motor}: no position")
        elif position is not None and position != axis_position(body, motor):
            wrong.append(f"{kind} a{body}{motor}: {position} not {axis_position(body, motor)}")
    return wrong


async def reader(
    client: httpx.AsyncClient, rng: random.Random, budget: list[int], seen: Counter[str],
    wrong: list[str],
) -> None:  # fmt: skip
    while budget[0] > 0:
        budget[0] -= 1
        body, motor, n = rng.choice(BODIES), rng.choice((1, 2)), rng.choice(ENTRIES)
        roll = rng.random()
        if roll < 0.3:
            kind, path = "entry", f"/controllers/c{body}/positions/{n}"
        elif roll < 0.35:
            kind, path = "speed", f"/axes/a{body}{motor}/speed"
        elif roll < 0.5:
            kind, path = "fresh", f"/axes/a{body}{motor}?fresh=true"
        else:
            kind, path = "cached", f"/axes/a{body}{motor}"
        response = await client.get(path)
        seen[f"{kind} {response.status_code}"] += 1
        assert response.status_code != 500, response.text
        if response.status_code == 200:
            seen["answers"] += 1
            wrong.extend(check(kind, body, motor, n, response.json()))


@pytest.mark.timeout(120)
async def test_late_replies_give_no_wrong_value_in_a_thousand_answers(tmp_path: Path) -> None:
    async with simulator(tmp_path) as (url, control):
        cell = tmp_path / "cell.toml"
        cell.write_text(
            CELL.format(
                port=url.rsplit(":", 1)[1],
                controllers="".join(CONTROLLER.format(body=b) for b in BODIES),
            )
        )
        options = ("--config", str(cell), "--no-auth", "--time-scale", str(SCALE))
        async with serve(tmp_path, *options) as gateway:
            async with httpx.AsyncClient(base_url=f"{gateway.url}/api/v1", timeout=30) as client:
                assert (await answered(client, "/axes/a11?fresh=true")).status_code == 200
                await write_truth(client)
                before = (await client.get("/loops/main")).json()["counters"]
                await control(op="fault", kind="late", probability=0.2, delay=0.09)
                began = time.monotonic()
                seen, wrong, budget = Counter[str](), list[str](), [ANSWERS * 21 // 20]
                rngs = [random.Random(300 + i) for i in range(READERS)]
                await asyncio.gather(*(reader(client, r, budget, seen, wrong) for r in rngs))
                wall = time.monotonic() - began
                await control(op="clear_faults")
                after = (await client.get("/loops/main")).json()["counters"]
            state = (await control(op="state"))["state"]
    late = after["late_replies"] - before["late_replies"]
    timeouts = after["timeouts"] - before["timeouts"]
    exchanges = after["exchanges"] - before["exchanges"]
    print(
        f"\nlate-reply campaign: {seen['answers']} answers in {wall:.1f} s, {len(wrong)} wrong;"
        f" {exchanges} exchanges, {late} late replies, {timeouts} time-outs;"
        f" {dict(sorted(seen.items()))}"
    )
    assert seen["answers"] >= ANSWERS, seen
    assert not wrong, wrong[:20]
    assert late > 0.05 * exchanges, (late, exchanges)  # the faults were there
    # The simulator's truth is what the readers were checked against.
    for body in BODIES:
        axes = state_axes(state, body)
        for motor in (1, 2):
            assert axes[str(motor)]["position"] == axis_position(body, motor), axes


def state_axes(state: dict[str, Any], body: str) -> dict[str, Any]:
    """The simulator's axes of controller ``body`` (its control port's ``state``)."""
    for unit in state["units"]:
        if unit["name"] == body:
            axes: dict[str, Any] = unit["controller"]["axes"]
            return axes
    raise AssertionError(f"no controller {body} in {state}")
