"""The feed on the real app and a simulated loop: 200 clients watch an axis move.

The axis is moved through the REST API (``POST /axes/x/move?wait=true``); the positions come
from the gateway's own polling of the simulated controller. Every client must receive every
change of the axis, in order: the same messages as a reader on the feed itself, ending at the
target with the axis stopped.
"""

from __future__ import annotations

import asyncio
import json
from typing import Any

import pytest
from websockets.asyncio.client import connect

from gateway.api.app import API_PREFIX
from tests.support.sim_app import running_app
from tests.support.ws_server import WsClient, start_uvicorn

CLIENTS = 200
TARGET_MM = 600.0  # axis x: 0.01 mm a pulse -> 60,000 pulses (soft limits -40 .. 940 mm)


@pytest.mark.slow
async def test_200_clients_receive_every_position_of_a_move_in_order() -> None:
    # Time scale 5: the 12 s move lasts 2.4 s here, long enough for the 50 ms polls to be
    # seen on the way even on a loaded host.
    async with running_app(("1",), scale=5.0) as api:
        feed = api.services.feed
        server, port = await start_uvicorn(api.app)
        clients: list[WsClient] = []
        try:
            url = f"ws://127.0.0.1:{port}{API_PREFIX}/ws"
            for chunk in range(0, CLIENTS, 50):
                conns = await asyncio.gather(
                    *(
                        connect(url, compression=None, close_timeout=2)
                        for _ in range(chunk, chunk + 50)
                    )
                )
                clients += [WsClient(c) for c in conns]
            snapshots = await asyncio.gather(*(c.subscribe("axis:x") for c in clients))
            assert {s["type"] for s in snapshots} == {"snapshot"}
            reference = feed.open(backlog=100_000)
            reference.subscribe(["axis:x"])
            assert json.loads(await reference.get())["type"] == "snapshot"

            # Polls go on while the clients subscribe: compare what came after this point.
            start = feed.seq
            response = await api.client.post(
                "/axes/x/move?wait=true&timeout=30", json={"position": TARGET_MM, "unit": "user"}
            )
            assert response.status_code == 200, response.text
            expected: list[dict[str, Any]] = []
            while reference.pending:
                message = json.loads(await reference.get())
                if message["seq"] > start:
                    expected.append(message)
            # Operation events about the axis come too (the resource's subscribers get them).
            moves = [m for m in expected if m["type"] == "change"]
            positions = [m["data"]["position"] for m in moves if "position" in m["changed"]]
            assert len(positions) >= 3  # the move was seen on its way, not just at the end
            assert positions[-1] == 60_000
            assert positions == sorted(positions)  # a move in one direction
            assert moves[-1]["data"]["moving"] is False
            assert {m["type"] for m in expected} <= {"change", "event"}

            async def watch(client: WsClient) -> list[dict[str, Any]]:
                got: list[dict[str, Any]] = []
                while not got or got[-1]["seq"] < expected[-1]["seq"]:
                    message = await client.recv()
                    if message["seq"] > start:
                        got.append(message)
                return got

            received = await asyncio.gather(*(watch(c) for c in clients))
            for got in received:
                assert [m["seq"] for m in got] == [m["seq"] for m in expected]
                assert got == expected
        finally:
            await asyncio.gather(*(c.close() for c in clients))
            await server.shutdown()
