"""The processes bench/line_outside.py starts besides the gateway and the simulator.

Each runs as ``python bench/outside_parts.py ROLE ...`` in its own process, so that what it
measures is not delayed by the other parts' work:

* ``proxy``: TCP proxies that stamp every chunk of bytes (``time.monotonic``, the clock every
  process of the machine shares) as they pass between a host and a simulator, and write the
  record (JSON lines) when told to stop (SIGTERM).
* ``naive``: the bar for position updates: a blocking pyserial loop that starts a move with the
  frames it is given and then asks ``$16`` as fast as the replies come, on the same kind of
  line (``socket://`` through the proxy); prints replies a second.
* ``bare``: a bare FastAPI app with one constant route on the uvicorn settings ``serve`` uses.
* ``load``: ``--connections`` keep-alive HTTP/1.1 connections asking one URL as fast as the
  answers come, on a minimal client (a full client library costs more CPU than the server);
  prints requests a second.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import signal
import socket
import sys
import time
from typing import Any

# --------------------------------------------------------------------------- proxy


class _Half(asyncio.Protocol):
    """One side of a proxied connection: what it receives is stamped and passed on."""

    def __init__(self, record: list[tuple[float, str, str, str]], name: str, way: str) -> None:
        self.record, self.name, self.way = record, name, way
        self.peer: asyncio.Transport | None = None
        self.transport: asyncio.Transport | None = None
        self.early: list[bytes] = []

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        sock = transport.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def data_received(self, data: bytes) -> None:
        self.record.append((time.monotonic(), self.name, self.way, data.decode("latin-1")))
        if self.peer is None:
            self.early.append(data)
        else:
            self.peer.write(data)

    def connection_lost(self, exc: Exception | None) -> None:
        if self.peer is not None:
            self.peer.close()


async def _proxy(pairs: list[tuple[str, int, int]], out: str) -> None:
    record: list[tuple[float, str, str, str]] = []
    aio = asyncio.get_running_loop()
    stop = asyncio.Event()
    aio.add_signal_handler(signal.SIGTERM, stop.set)

    def factory(name: str, upstream: int) -> Any:
        def make() -> _Half:
            host = _Half(record, name, "h2d")

            async def connect() -> None:
                _, device = await aio.create_connection(
                    lambda: _Half(record, name, "d2h"), "127.0.0.1", upstream
                )
                assert isinstance(device, _Half) and device.transport is not None
                assert host.transport is not None
                device.peer, host.peer = host.transport, device.transport
                for data in host.early:
                    device.transport.write(data)

            aio.create_task(connect())  # noqa: RUF006 (lives as long as the process)
            return host

        return make

    servers = []
    for name, listen, upstream in pairs:
        servers.append(await aio.create_server(factory(name, upstream), "127.0.0.1", listen))
    print("ready", flush=True)
    await stop.wait()
    with open(out, "w") as file:
        for row in record:
            file.write(json.dumps(row) + "\n")


# --------------------------------------------------------------------------- naive peer


def _naive(url: str, move: list[str], seconds: float) -> None:
    import serial  # type: ignore[import-untyped]

    port = serial.serial_for_url(url, baudrate=9600, timeout=1.0)
    for frame in move:  # commands answered by a bare acknowledgement, ">"
        port.write(frame.encode("latin-1"))
        port.read(1)
    replies, start, seen = 0, time.monotonic(), []
    while time.monotonic() - start < seconds:
        port.write(b"$16\r")  # ">$1" + 8 digits + CR
        reply = port.read_until(b"\r")
        if reply.endswith(b"\r"):
            replies += 1
            seen.append(reply[3:-1].decode())
    elapsed = time.monotonic() - start
    port.write(b"$1S\r")
    port.read(1)
    port.close()
    moved = len(set(seen)) > 1
    figures = {"replies": replies, "per_second": replies / elapsed, "start": start, "moved": moved}
    print(json.dumps({**figures, "end": start + elapsed}), flush=True)


# --------------------------------------------------------------------------- bare app


def _bare(port: int) -> None:
    import logging

    import uvicorn
    from fastapi import FastAPI

    logging.basicConfig(level=logging.INFO, stream=sys.stderr)
    app = FastAPI()
    body = {"id": "bench.1.1", "name": "x", "position": 0, "state": "idle"}

    @app.get("/api/v1/bare")
    async def bare() -> dict[str, Any]:
        return body

    print("ready", flush=True)
    uvicorn.run(app, host="127.0.0.1", port=port, log_level="info", log_config=None)


# --------------------------------------------------------------------------- HTTP load


async def _one_connection(port: int, request: bytes, until: float, counts: list[int]) -> None:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    done = 0
    while time.monotonic() < until:
        writer.write(request)
        length = -1
        while True:
            line = await reader.readline()
            if line in (b"\r\n", b""):
                break
            if line[:15].lower() == b"content-length:":
                length = int(line[15:])
        await reader.readexactly(max(0, length))
        done += 1
    counts.append(done)
    writer.close()


async def _load(port: int, path: str, connections: int, seconds: float) -> None:
    request = f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode()
    counts: list[int] = []
    start = time.monotonic()
    until = start + seconds
    await asyncio.gather(
        *(_one_connection(port, request, until, counts) for _ in range(connections))
    )
    elapsed = time.monotonic() - start
    print(json.dumps({"requests": sum(counts), "per_second": sum(counts) / elapsed}), flush=True)


def main() -> None:
    """Run one role."""
    parser = argparse.ArgumentParser()
    role = parser.add_subparsers(dest="role", required=True)
    proxy = role.add_parser("proxy")
    proxy.add_argument("--pair", action="append", default=[], help="NAME:LISTEN:UPSTREAM")
    proxy.add_argument("--out", required=True)
    naive = role.add_parser("naive")
    naive.add_argument("--url", required=True)
    naive.add_argument("--move", action="append", default=[])
    naive.add_argument("--seconds", type=float, default=5.0)
    bare = role.add_parser("bare")
    bare.add_argument("--port", type=int, required=True)
    load = role.add_parser("load")
    load.add_argument("--port", type=int, required=True)
    load.add_argument("--path", required=True)
    load.add_argument("--connections", type=int, default=16)
    load.add_argument("--seconds", type=float, default=5.0)
    args = parser.parse_args()
    if args.role == "proxy":
        pairs = [(n, int(a), int(b)) for n, a, b in (p.split(":") for p in args.pair)]
        asyncio.run(_proxy(pairs, args.out))
    elif args.role == "naive":
        _naive(args.url, args.move, args.seconds)
    elif args.role == "bare":
        _bare(args.port)
    else:
        asyncio.run(_load(args.port, args.path, args.connections, args.seconds))


if __name__ == "__main__":
    main()
