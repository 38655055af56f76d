"""The API's connections under attack: a real ``serve`` process, real sockets on loopback.

A client that sends a huge head, trickles it, sends nothing or opens connection after
connection must cost the gateway a bounded amount, and an operator's stop must still be
heard (gateway/cli/connection_guard.py, ``[connections]`` of the configuration).
"""

from __future__ import annotations

import asyncio
import contextlib
import resource
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import httpx
import pytest
from websockets.asyncio.client import connect as ws_connect

from gateway.api.security import hash_token
from gateway.service.config import ConfigError, parse_config
from tests.support.serve_process import TIME_SCALE, Served, serve

OPERATOR = "OPERtok-conn-4c1d9e7a"
WAIT = 15.0

CELL = f"""
[[security.tokens]]
name = "mes"
role = "operator"
sha256 = "{hash_token(OPERATOR)}"

[connections]
{{limits}}

[[loops]]
name = "cell"
port = "/dev/serial/by-id/not-here"   # replaced by a simulated loop

[[loops.controllers]]
body = "4"
name = "press"

[[loops.controllers.axes]]
motor = 1
name = "ram"
"""


@asynccontextmanager
async def gateway(
    tmp_path: Path, limits: str = "", files: int | None = None
) -> AsyncIterator[Served]:
    path = tmp_path / "cell.toml"
    path.write_text(CELL.format(limits=limits), "utf-8")
    options = ("--simulate", "--config", str(path), "--time-scale", str(TIME_SCALE))
    async with serve(tmp_path, *options, files=files) as served:
        yield served


async def connect(
    port: int, source: str = "127.0.0.1"
) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    return await asyncio.open_connection("127.0.0.1", port, local_addr=(source, 0))


async def answer(reader: asyncio.StreamReader) -> bytes:
    """Everything the gateway sends until it closes the connection."""
    return await asyncio.wait_for(reader.read(), WAIT)


async def test_a_head_over_the_limit_is_answered_431_and_closed(tmp_path: Path) -> None:
    async with gateway(tmp_path) as server:
        # An unfinished header of 2 MB: refused once it passes 16 KiB, not buffered.
        reader, writer = await connect(server.port)
        writer.write(b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Pad: " + b"a" * 2_000_000)
        reply = await answer(reader)
        assert reply.startswith(b"HTTP/1.1 431 "), reply[:200]
        writer.close()
        # Complete, but many headers: refused as well.
        reader, writer = await connect(server.port)
        many = b"".join(b"X-%d: %s\r\n" % (i, b"b" * 100) for i in range(200))
        writer.write(b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n" + many + b"\r\n")
        reply = await answer(reader)
        assert reply.startswith(b"HTTP/1.1 431 "), reply[:200]
        writer.close()
        async with httpx.AsyncClient(base_url=server.url) as client:
            assert (await client.get("/healthz", headers={"X-Pad": "c" * 8000})).status_code == 200


async def test_silent_and_trickling_connections_are_closed(tmp_path: Path) -> None:
    limits = "idle_timeout = 0.5\nhead_timeout = 1.0"
    async with gateway(tmp_path, limits) as server:
        silent, silent_writer = await connect(server.port)
        started = time.monotonic()
        assert await answer(silent) == b""
        assert time.monotonic() - started < 5
        slow, slow_writer = await connect(server.port)
        head = b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: " + b"z" * 100

        async def trickle() -> None:
            for byte in head:  # a byte every 50 ms: the head would take 5 s
                slow_writer.write(bytes([byte]))
                await asyncio.sleep(0.05)

        sender = asyncio.create_task(trickle())
        reply = await answer(slow)
        sender.cancel()
        assert reply.startswith(b"HTTP/1.1 408 "), reply
        for writer in (silent_writer, slow_writer):
            writer.close()


async def test_one_address_gets_its_share_of_connections(tmp_path: Path) -> None:
    async with gateway(tmp_path, "max_per_client = 4") as server:
        held = [await connect(server.port, "127.0.0.2") for _ in range(4)]
        reader, writer = await connect(server.port, "127.0.0.2")
        assert (await answer(reader)).startswith(b"HTTP/1.1 429 ")
        writer.close()
        async with httpx.AsyncClient(base_url=server.url) as client:  # 127.0.0.1: its own share
            assert (await client.get("/healthz")).status_code == 200
        held[0][1].close()
        await held[0][1].wait_closed()
        async with asyncio.timeout(WAIT):
            while True:  # the freed place is given again once the gateway saw the close
                reader, writer = await connect(server.port, "127.0.0.2")
                writer.write(b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
                line = await asyncio.wait_for(reader.readline(), WAIT)
                writer.close()
                if line.startswith(b"HTTP/1.1 200 "):
                    break
        for _, held_writer in held:
            held_writer.close()
    # One line for the refusals of a minute, not one per connection.
    assert len([line for line in server.log if "connections: 1 refused" in line]) == 1


async def healthz_from(port: int, source: str) -> bool:
    """Whether ``GET /healthz`` from ``source`` is answered 200 (not refused)."""
    reader, writer = await connect(port, source)
    writer.write(b"GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
    line = await asyncio.wait_for(reader.readline(), WAIT)
    writer.close()
    return line.startswith(b"HTTP/1.1 200 ")


async def test_a_websocket_keeps_its_place_until_it_closes(tmp_path: Path) -> None:
    async with gateway(tmp_path, "max_per_client = 1") as server:
        url = f"ws://127.0.0.1:{server.port}/api/v1/ws?token={OPERATOR}"
        async with ws_connect(url, local_addr=("127.0.0.3", 0), open_timeout=WAIT) as ws:
            await ws.send('{"type": "ping", "id": "1"}')
            assert '"pong"' in str(await asyncio.wait_for(ws.recv(), WAIT))
            assert not await healthz_from(server.port, "127.0.0.3")  # its one place is taken
        async with asyncio.timeout(WAIT):
            while not await healthz_from(server.port, "127.0.0.3"):
                pass  # given back once the gateway saw the WebSocket close


def _rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


def _own_files(at_least: int) -> None:
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft < at_least:
        assert hard >= at_least, f"the test needs {at_least} descriptors (ulimit -Hn {hard})"
        resource.setrlimit(resource.RLIMIT_NOFILE, (at_least, hard))


async def test_1500_hostile_connections_leave_room_for_a_stop(tmp_path: Path) -> None:
    hostile = 1500
    _own_files(hostile + 500)
    # systemd's soft limit without LimitNOFILE: 1,024 descriptors.
    async with gateway(tmp_path, files=1024) as server:
        auth = {"Authorization": f"Bearer {OPERATOR}", "Content-Type": "application/json"}
        async with httpx.AsyncClient(base_url=server.url, timeout=WAIT) as client:
            assert (await client.get("/healthz")).status_code == 200
            assert (await client.post("/api/v1/axes/ram/stop", headers=auth)).status_code == 200
        before = _rss_kib(server.pid)
        # 60 from each of 25 loopback addresses, each with an unfinished 8 KB head.
        peers = []
        for i in range(hostile):
            peer = await connect(server.port, f"127.0.0.{2 + i // 60}")
            peer[1].write(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Pad: " + b"h" * 8000)
            peers.append(peer)
        closed = 0
        taken = asyncio.Event()

        async def count_closed(reader: asyncio.StreamReader) -> None:
            nonlocal closed
            await reader.read()
            closed += 1
            if closed >= hostile - 1024:
                taken.set()

        watchers = [asyncio.create_task(count_closed(r)) for r, _ in peers]
        # The gateway took them all once it closed the oldest ones past its limit (1,024);
        # without a limit nothing closes, and the requests below show what that costs.
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(taken.wait(), WAIT)
        async with httpx.AsyncClient(base_url=server.url, timeout=WAIT) as client:
            started = time.monotonic()
            health = await client.get("/healthz")
            health_time = time.monotonic() - started
            started = time.monotonic()
            stop = await client.post("/api/v1/axes/ram/stop", headers=auth)
            stop_time = time.monotonic() - started
        after = _rss_kib(server.pid)
        for watcher in watchers:
            watcher.cancel()
        for _, writer in peers:
            writer.close()
    assert health.status_code == 200 and stop.status_code == 200, stop.text
    assert health_time < 0.2 and stop_time < 0.2, (health_time, stop_time)
    assert after - before < 50 * 1024, f"RSS grew {(after - before) // 1024} MB"


@pytest.mark.parametrize(
    ("key", "value"),
    [("max_head_bytes", 100), ("idle_timeout", 0), ("head_timeout", -1), ("max_per_client", 0),
     ("max_connections", 1), ("sockets", 3)],
)  # fmt: skip
def test_a_bad_connection_limit_is_named(key: str, value: int) -> None:
    loop = {"name": "cell", "port": "/dev/null", "controllers": [{"body": "1"}]}
    with pytest.raises(ConfigError) as refused:
        parse_config({"loops": [loop], "connections": {key: value}})
    assert f"  connections.{key}:" in str(refused.value)
