"""A short soak: clients that come and go leave nothing behind in the gateway.

The real app on a simulated loop behind a real uvicorn server in this process, with the
connection guard and the WebSocket options ``serve`` gives it: 200 WebSocket clients connect,
subscribe to every topic, take their snapshot and leave (half of them closing, half vanishing
without a close frame), then 200 HTTP keep-alive connections make cached and fresh reads and
close. Afterwards the process's asyncio tasks and open descriptors are back at their count
before the clients came, and every table kept per client or connection is empty: the feed's
clients, the connection book's, the fresh-read gate's. Counts, not RSS: a leak of one task or
one socket a client is found at once, where memory would need hours to tell.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
from collections.abc import Callable
from typing import Any

import pytest
from websockets.asyncio.client import connect

from gateway.api.middleware.fresh_reads import FreshReadGate
from gateway.api.ws import endpoint as ws
from gateway.cli.connection_guard import ConnectionBook, uvicorn_connection_options
from gateway.service.config import ConnectionSettings
from tests.support.sim_app import running_app
from tests.support.state_waits import until_state
from tests.support.ws_server import start_uvicorn

TOPICS = ["axis:*", "controller:*", "loop:*", "events"]
CYCLES = 200
AT_ONCE = 10  # WebSocket clients side by side
KEEP_ALIVE_AT_ONCE = 50  # under the connection guard's 64 a client address


def _fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def _fresh_gate(app: Any) -> FreshReadGate:
    layer = app.middleware_stack
    while layer is not None and not isinstance(layer, FreshReadGate):
        layer = getattr(layer, "app", None)
    assert isinstance(layer, FreshReadGate), "the app has no fresh-read gate"
    return layer


async def _ws_cycle(port: int, vanish: bool) -> None:
    url = f"ws://127.0.0.1:{port}/api/v1/ws"
    async with connect(url, compression=None, open_timeout=20, close_timeout=5) as client:
        await client.send(json.dumps({"type": "subscribe", "topics": TOPICS}))
        first = json.loads(await asyncio.wait_for(client.recv(), 20))
        assert first["type"] == "snapshot", first
        if vanish:  # gone without a close frame: a pulled cable, a killed browser tab
            client.transport.abort()


async def _request(reader: asyncio.StreamReader, writer: asyncio.StreamWriter, path: str) -> int:
    writer.write(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode())
    status = int((await reader.readline()).split()[1])
    length = 0
    while (line := await reader.readline()) not in (b"\r\n", b""):
        if line.lower().startswith(b"content-length:"):
            length = int(line[15:])
    await reader.readexactly(length)
    return status


async def _keep_alive_cycle(port: int) -> None:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        for path in ("/api/v1/axes/x", "/api/v1/axes/x?fresh=true", "/api/v1/operations"):
            assert await _request(reader, writer, path) == 200, path
    finally:
        writer.close()
        await writer.wait_closed()


def _left(api: Any, book: ConnectionBook, gate: FreshReadGate) -> dict[str, int]:
    return {
        "tasks": len(asyncio.all_tasks()),
        "fds": _fds(),
        "feed clients": api.services.feed.clients,
        "connections": len(book.open),
        "client addresses": len(book.per_client),
        "waiting connections": len(book.waiting),
        "fresh-read callers": gate.callers,
    }


async def _wait(api: Any, check: Callable[[], bool]) -> None:
    """Until ``check()`` holds (the server closes what clients left on its own time), at
    most 30 s: the assertions after it say what was left."""
    with contextlib.suppress(TimeoutError):
        await until_state(api.runtime.state, check, 30)


@pytest.mark.timeout(120)
async def test_clients_that_come_and_go_leave_no_task_socket_or_table_entry() -> None:
    async with running_app() as api:
        options = uvicorn_connection_options(ConnectionSettings())
        book: ConnectionBook = options["http"].book
        options |= ws.uvicorn_ws_options(api.runtime.config.ws)
        server, port = await start_uvicorn(api.app, **options)
        try:
            # One of each first: whatever is made once, on first use, is made now.
            await _ws_cycle(port, vanish=False)
            await _keep_alive_cycle(port)
            gate = _fresh_gate(api.app)
            idle = {"feed clients": 0, "connections": 0, "client addresses": 0,
                    "waiting connections": 0, "fresh-read callers": 0}  # fmt: skip

            def settled(start: dict[str, int]) -> bool:
                now = _left(api, book, gate)
                return all(now[k] <= v for k, v in start.items())

            await _wait(api, lambda: settled(idle))
            start = _left(api, book, gate)
            assert {k: start[k] for k in idle} == idle, "the first client left something"
            for n in range(0, CYCLES, AT_ONCE):
                await asyncio.gather(*(_ws_cycle(port, vanish=i % 2 == 1)
                                       for i in range(n, n + AT_ONCE)))  # fmt: skip
            for _ in range(0, CYCLES, KEEP_ALIVE_AT_ONCE):
                await asyncio.gather(*(_keep_alive_cycle(port) for _ in range(KEEP_ALIVE_AT_ONCE)))
            await _wait(api, lambda: settled(start))
            left = _left(api, book, gate)
        finally:
            await server.shutdown()
    assert {k: left[k] for k in idle} == idle
    assert left["tasks"] <= start["tasks"], (start, left)
    assert left["fds"] <= start["fds"], (start, left)
