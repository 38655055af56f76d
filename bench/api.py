"""What the API costs: cached axis reads against a trivial route, and WebSocket fan-out lag.

A server process runs the real app (``create_app``) on an in-process simulated loop (three
controllers, real-time line timing, polling as in production) under uvicorn on 127.0.0.1;
this process is the clients. Two figures:

* ``http``: requests per second of ``GET /api/v1/axes/{id}`` (the cached state, no line
  traffic) against ``GET /api/v1/bench/trivial`` (a route that returns a constant) on the
  same server and middleware, with ``--concurrency`` httpx clients on keep-alive
  connections; ``ratio`` = axes / trivial (target >= 0.7). The server's CPU time per request
  is printed too: the client process may be what limits the request rate.
* ``ws``: ``--clients`` WebSocket clients subscribed to one axis while the server changes that
  axis ``--rate`` times a second (a position reply fed to the gateway's state cache, as the
  scheduler feeds it); the lag of each delivered change is the client's receive time minus
  the message's ``time`` (the server's wall clock when the feed published it): p50, p99 and
  max in milliseconds (target p99 <= 50 ms), and whether every client got every change.
  ``server_publish_ms`` is the server's own part: one change from the state cache to the
  last client written in the same call (p50, p99, max), with the collections the collector
  ran meanwhile. The clients read frames with a dozen bytecodes each (``LightClient``) on
  uvloop: with the websockets library parsing 1,000 sockets' frames, this process was the
  larger part of the lag it measured.

    .venv/bin/python bench/api.py                         # 5 s each, 1,000 clients
    .venv/bin/python bench/api.py --quick                 # what make bench runs

It prints one JSON object.
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import json
import os
import socket
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

import httpx
from websockets.client import ClientProtocol
from websockets.frames import Opcode
from websockets.http11 import Response
from websockets.uri import parse_uri

AXIS = "x"  # sim.1.1
MARKER = 99_999  # the position that ends a fan-out run
#: every request that acts is declared JSON, bodyless too (the gateway refuses it otherwise)
JSON_ACT = {"Content-Type": "application/json"}


# --------------------------------------------------------------------------- the server


async def serve(rate_limit: int) -> None:
    """The server process: the app on a simulated loop; prints its port, runs until killed."""
    import uvicorn
    from fastapi import FastAPI

    from gateway.api.app import API_PREFIX, create_app
    from gateway.api.security import AuthConfig
    from gateway.api.ws import endpoint as ws
    from gateway.bus.events import ReplyObserved
    from gateway.compose import compose
    from gateway.protocol.command_text import parse
    from gateway.service.runtime.runtime import Runtime
    from gateway.service.runtime.simulated import SIM_LOOP, simulated_config
    from gateway.sim.cli import build_loop
    from gateway.sim.clock import SimClock
    from gateway.sim.serve import SimPort
    from gateway.transport.pipe import PipeTransport

    sim = build_loop(["1", "2", "3"], clock=SimClock(1.0))
    config = simulated_config(("1", "2", "3"))
    transport = PipeTransport(lambda: SimPort(sim))
    gateway = Runtime(config, transports={SIM_LOOP: transport})
    app: FastAPI = create_app(compose(gateway), auth=AuthConfig(no_auth=True))

    @app.get(f"{API_PREFIX}/bench/trivial")
    async def trivial() -> dict[str, bool]:
        return {"ok": True}

    publish_ms: list[float] = []
    # Collections during the fan-out, by generation: (count, longest pause in ms). A pause
    # of the whole process shows in the lag; the heap is frozen before it, as serve does.
    collections: dict[int, list[float]] = {}
    collecting: list[float] = []

    def on_gc(phase: str, info: dict[str, int]) -> None:
        if phase == "start":
            collecting.append(time.perf_counter())
        elif collecting:
            took = (time.perf_counter() - collecting.pop()) * 1000
            seen = collections.setdefault(info["generation"], [0, 0.0])
            seen[0] += 1
            seen[1] = max(seen[1], took)

    async def inject(rate: float, seconds: float) -> None:
        # Positions the poller never reads back (it reads motor 1 when idle, every second,
        # and finds the simulator's 0): distinct values a client can count. The last one,
        # MARKER, tells the clients the run is over.
        command, start = parse("61"), time.monotonic()
        due = start
        for pulses in [*range(100_001, 100_001 + round(rate * seconds)), MARKER]:
            reply = ReplyObserved(
                loop=SIM_LOOP, time=time.monotonic(), body="1", command=command, value=pulses
            )
            began = time.perf_counter()
            gateway.state.handle(reply)  # the feed publishes it to every client in this call
            publish_ms.append((time.perf_counter() - began) * 1000)
            due += 1 / rate
            await asyncio.sleep(max(0.0, due - time.monotonic()))

    tasks: set[asyncio.Task[None]] = set()

    @app.post(f"{API_PREFIX}/bench/inject")
    async def start_injecting(rate: float, seconds: float, freeze: bool) -> dict[str, bool]:
        if freeze:  # what a server can do once started: no GC pass scans the startup heap
            gc.collect()
            gc.freeze()
        collections.clear()
        if on_gc not in gc.callbacks:
            gc.callbacks.append(on_gc)
        task = asyncio.create_task(inject(min(rate, rate_limit), seconds))
        tasks.add(task)
        task.add_done_callback(tasks.discard)
        return {"started": True}

    @app.get(f"{API_PREFIX}/bench/publish")
    async def publish() -> dict[str, Any]:
        # The feed's own share of the lag: from the change to the last direct write.
        times = sorted(publish_ms)
        q = statistics.quantiles(times, n=100, method="inclusive") if len(times) > 1 else [0.0] * 99
        gcs = {f"gen{g}": [n, round(ms, 2)] for g, (n, ms) in sorted(collections.items())}
        clients = list(app.state.services.feed._clients)
        return {
            # Clients the feed writes through their queue and sender task only.
            "clients_without_direct_writer": sum(c.direct is None for c in clients),
            "p50": round(q[49], 2),
            "p99": round(q[98], 2),
            "max": round(times[-1], 2),
            "gc_collections_and_longest_ms": gcs,
        }

    @app.get(f"{API_PREFIX}/bench/cpu")
    async def cpu() -> dict[str, float]:
        usage = os.times()
        return {"cpu": usage.user + usage.system}

    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(("127.0.0.1", 0))
    sock.listen(4096)
    options = ws.uvicorn_ws_options(config.ws)
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", backlog=4096, **options))
    print(sock.getsockname()[1], flush=True)
    await server.serve(sockets=[sock])


# --------------------------------------------------------------------------- HTTP


async def rate_of(client: httpx.AsyncClient, path: str, seconds: float, workers: int) -> float:
    """Requests per second of ``path`` with ``workers`` concurrent requesters."""
    count, end = 0, time.perf_counter() + seconds

    async def worker() -> None:
        nonlocal count
        while time.perf_counter() < end:
            response = await client.get(path)
            assert response.status_code == 200, response.text
            count += 1

    start = time.perf_counter()
    await asyncio.gather(*(worker() for _ in range(workers)))
    return count / (time.perf_counter() - start)


async def http_bench(base: str, seconds: float, workers: int) -> dict[str, Any]:
    limits = httpx.Limits(max_connections=workers, max_keepalive_connections=workers)
    async with httpx.AsyncClient(base_url=base, limits=limits, timeout=30) as client:
        axis = (await client.get(f"/axes/{AXIS}")).json()
        assert axis["id"] == "sim.1.1", axis
        await rate_of(client, "/bench/trivial", 0.5, workers)  # warm up
        figures: dict[str, list[float]] = {"trivial": [], "axes": []}
        cpu: dict[str, float] = {"trivial": 0.0, "axes": 0.0}
        counts: dict[str, float] = {"trivial": 0.0, "axes": 0.0}
        for _ in range(2):  # alternate, so that drift weighs on both
            for name, path in (("trivial", "/bench/trivial"), ("axes", f"/axes/{AXIS}")):
                before = (await client.get("/bench/cpu")).json()["cpu"]
                rps = await rate_of(client, path, seconds / 4, workers)
                after = (await client.get("/bench/cpu")).json()["cpu"]
                figures[name].append(rps)
                cpu[name] += after - before
                counts[name] += rps * seconds / 4
    trivial, axes = statistics.mean(figures["trivial"]), statistics.mean(figures["axes"])
    return {
        "trivial_rps": round(trivial),
        "axes_rps": round(axes),
        "ratio": round(axes / trivial, 3),
        "target_ratio": 0.7,
        "server_cpu_us_per_request": {
            k: round(1e6 * cpu[k] / counts[k], 1) for k in ("trivial", "axes")
        },
        "concurrency": workers,
    }


# --------------------------------------------------------------------------- WebSocket


async def server_cpu(client: httpx.AsyncClient) -> float:
    """CPU seconds the server process used so far."""
    return float((await client.get("/bench/cpu")).json()["cpu"])


def own_cpu() -> float:
    """CPU seconds this process used so far."""
    usage = os.times()
    return usage.user + usage.system


class LightClient(asyncio.Protocol):
    """A WebSocket client that stamps each frame when its bytes arrive and does little else,
    so that 1,000 of them in one process read their sockets soon after the server wrote them
    (the lag is the server's fan-out plus the time this process takes to come to a socket).

    The handshake goes through the websockets library's sans-I/O protocol, which also frames
    what the client sends (masked, as RFC 6455 wants); what the server sends after it is read
    here: unmasked frames, text or ping (answered with a pong), a dozen bytecodes a frame
    rather than the library's generator-based parser."""

    def __init__(self, uri: str, on_text: Callable[[float, bytes], None]) -> None:
        self.protocol = ClientProtocol(parse_uri(uri), max_size=None)
        self.on_text = on_text
        self.opened: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self.transport: Any = None  # uvloop's transports are no asyncio.Transport
        self.raw = False  # True once the handshake is done: frames are read here
        self.pending = b""  # the start of a frame whose end has not come yet

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport
        self.protocol.send_request(self.protocol.connect())
        self.flush()

    def data_received(self, data: bytes) -> None:
        now = time.time()
        if self.raw:
            self.frames(now, data)
            return
        self.protocol.receive_data(data)
        for event in self.protocol.events_received():
            if isinstance(event, Response) and not self.opened.done():
                # The server says nothing before the client subscribes: no frame is held
                # in the library's buffer when reading switches to frames().
                self.raw = True
                self.opened.set_result(None)
        self.flush()

    def frames(self, now: float, data: bytes) -> None:
        buf = self.pending + data if self.pending else data
        at, end = 0, len(buf)
        while end - at >= 2:
            first, size = buf[at], buf[at + 1]
            assert not size & 0x80 and first & 0x80, "a server frame: unmasked, final"
            size &= 0x7F
            head = 2
            if size == 126:
                if end - at < 4:
                    break
                size, head = int.from_bytes(buf[at + 2 : at + 4], "big"), 4
            elif size == 127:
                if end - at < 10:
                    break
                size, head = int.from_bytes(buf[at + 2 : at + 10], "big"), 10
            stop = at + head + size
            if stop > end:
                break
            opcode = first & 0x0F
            if opcode == Opcode.TEXT.value:
                self.on_text(now, buf[at + head : stop])
            elif opcode == Opcode.PING.value:
                self.pong(buf[at + head : stop])
            at = stop
        self.pending = buf[at:]

    def pong(self, payload: bytes) -> None:
        assert self.transport is not None
        mask = os.urandom(4)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        self.transport.write(bytes((0x8A, 0x80 | len(payload))) + mask + masked)

    def send_text(self, text: str) -> None:
        self.protocol.send_text(text.encode())
        self.flush()

    def flush(self) -> None:
        assert self.transport is not None
        for data in self.protocol.data_to_send():
            if data:
                self.transport.write(data)

    def close(self) -> None:
        if self.transport is not None:
            self.transport.close()


async def ws_bench(
    base: str, port: int, clients: int, rate: float, seconds: float, freeze: bool
) -> dict[str, Any]:
    loop = asyncio.get_running_loop()
    url = f"ws://127.0.0.1:{port}/api/v1/ws"
    arrived: list[tuple[int, float, bytes]] = []  # decoded after the run: no JSON meanwhile
    snapshots, finished = asyncio.Event(), asyncio.Event()
    subscribed = done = 0
    marker = f'"position":{MARKER},'.encode()

    def receiver(i: int) -> Callable[[float, bytes], None]:
        def on_text(now: float, data: bytes) -> None:
            nonlocal subscribed, done
            if snapshots.is_set():
                arrived.append((i, now, data))
                if marker in data:
                    done += 1
                    if done == clients:
                        finished.set()
            elif json.loads(data)["type"] == "snapshot":
                subscribed += 1
                if subscribed == clients:
                    snapshots.set()

        return on_text

    conns: list[LightClient] = []
    for start in range(0, clients, 100):
        batch = range(start, min(start + 100, clients))
        made = await asyncio.gather(
            *(
                loop.create_connection(lambda i=i: LightClient(url, receiver(i)), "127.0.0.1", port)
                for i in batch
            )
        )
        conns += [protocol for _, protocol in made]
        await asyncio.gather(*(c.opened for c in conns[start:]))
    for conn in conns:
        conn.send_text(json.dumps({"type": "subscribe", "topics": [f"axis:{AXIS}"]}))
    await asyncio.wait_for(snapshots.wait(), 60)
    # No collection in this process while it stamps arrivals: a full pass over the 100,000
    # arrivals it keeps paused the reading of every socket by 100-400 ms, now and then.
    gc.collect()
    gc.freeze()
    gc.disable()
    async with httpx.AsyncClient(base_url=base) as client:
        server_before, own_before, start = await server_cpu(client), own_cpu(), time.monotonic()
        params = {"rate": rate, "seconds": seconds, "freeze": freeze}
        response = await client.post("/bench/inject", params=params, headers=JSON_ACT)
        assert response.status_code == 200, response.text
        expected = round(rate * seconds)
        await asyncio.wait_for(finished.wait(), seconds + 60)
        elapsed = time.monotonic() - start
        server_share = (await server_cpu(client) - server_before) / elapsed
        client_share = (own_cpu() - own_before) / elapsed
        publish = (await client.get("/bench/publish")).json()
    gc.enable()
    for conn in conns:
        conn.close()
    lags, counts = [], [0] * clients
    for i, now, data in arrived:
        message = json.loads(data)
        if message["type"] == "change" and message["data"]["position"] > MARKER:
            lags.append(now - message["time"])
            counts[i] += 1
    lags_ms = sorted(1000 * lag for lag in lags)
    q = statistics.quantiles(lags_ms, n=100) if len(lags_ms) > 1 else [0.0] * 99
    return {
        "clients": clients,
        "changes_per_second": rate,
        "server_gc_freeze": freeze,
        "delivered": len(lags_ms),
        "every_client_got_every_change": min(counts) >= expected,
        "lag_ms_p50": round(q[49], 2),
        "lag_ms_p99": round(q[98], 2),
        "lag_ms_max": round(lags_ms[-1], 2) if lags_ms else None,
        "target_p99_ms": 50,
        # One change from the state cache to the last client written in the same call
        # (encode once, a socket write per client): the server's part of the lag.
        "server_publish_ms": publish,
        "cpu_share": {"server": round(server_share, 2), "clients": round(client_share, 2)},
        # What the fan-out costs the server whatever else the machine runs (the lag is the
        # clients' too: on a busy machine they read 1,000 sockets late).
        "server_cpu_us_per_delivery": round(server_share * elapsed / max(1, len(lags_ms)) * 1e6, 1),
    }


# --------------------------------------------------------------------------- main


async def main(args: argparse.Namespace) -> dict[str, Any]:
    child = subprocess.Popen(
        [sys.executable, __file__, "--serve", "--rate", str(args.rate)]
        + (["--stock-loop"] if args.stock_loop else []),
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout is not None
        port = int(await asyncio.to_thread(child.stdout.readline))
        base = f"http://127.0.0.1:{port}/api/v1"
        async with httpx.AsyncClient(base_url=base, timeout=30) as client:
            deadline = time.monotonic() + 30  # the loop opens, the poller reads the axes
            while (await client.get(f"/axes/{AXIS}")).json().get("position") is None:
                assert time.monotonic() < deadline, "the simulated loop did not come up"
                await asyncio.sleep(0.1)
        http = await http_bench(base, args.seconds, args.concurrency)
        wsf = await ws_bench(base, port, args.clients, args.rate, args.seconds, args.gc_freeze)
    finally:
        child.terminate()
        child.wait(10)
    return {"seconds": args.seconds, "http": http, "websocket": wsf, "cpus": os.cpu_count()}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="per figure (real seconds)")
    parser.add_argument("--clients", type=int, default=1000, help="WebSocket clients")
    parser.add_argument("--rate", type=float, default=20.0, help="axis changes a second")
    parser.add_argument("--concurrency", type=int, default=16, help="HTTP requests in flight")
    parser.add_argument(
        "--no-gc-freeze",
        dest="gc_freeze",
        action="store_false",
        help="the server does not freeze its heap (gc.freeze, as serve does) before the fan-out",
    )
    parser.add_argument(
        "--stock-loop",
        action="store_true",
        help="the server on asyncio's own event loop instead of serve's (uvloop where installed)",
    )
    parser.add_argument("--quick", action="store_true", help="1 s, 200 clients (make bench)")
    parser.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.quick:
        args.seconds, args.clients = 1.0, 200
    return args


if __name__ == "__main__":
    arguments = parse_args()
    if arguments.serve:
        if arguments.stock_loop:
            runner = asyncio.Runner()
        else:
            from gateway.cli.serve import event_loop_runner

            runner = event_loop_runner()
        with runner:
            runner.run(serve(rate_limit=10_000))
    else:
        # The clients on uvloop too where it is installed: 1,000 sockets read at its cost.
        from gateway.cli.serve import event_loop_runner

        with event_loop_runner() as runner:
            print(json.dumps(runner.run(main(arguments)), indent=2))
