"""The busy figure is measured: behind a device server that adds latency, the line is held
longer than its wire time, and ``rc233_loop_busy_seconds_total`` shows it where the computed
``rc233_loop_wire_seconds_total`` cannot.

The simulated loop at real time is served over TCP; between it and the gateway a small proxy
holds every chunk ``DELAY`` seconds each way, as a slow serial device server does.
"""

from __future__ import annotations

import asyncio
import contextlib

from gateway.api.metrics.collector import Metrics
from gateway.cli.serve import open_lines
from gateway.protocol.command_text import parse
from gateway.service.config import parse_config
from gateway.service.runtime.runtime import Runtime
from gateway.sim.cli import build_loop
from gateway.sim.clock import SimClock
from gateway.sim.serve import serve_tcp
from tests.support.exposition import parse_exposition, value

DELAY = 0.03  # real seconds each way


async def _pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
    with contextlib.suppress(ConnectionError):
        while chunk := await reader.read(4096):
            await asyncio.sleep(DELAY)  # the device server's latency, not a synchronisation
            writer.write(chunk)
            await writer.drain()
    writer.close()


async def _slow_proxy(target: int) -> asyncio.Server:
    async def client(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        up_reader, up_writer = await asyncio.open_connection("127.0.0.1", target)
        await asyncio.gather(_pipe(reader, up_writer), _pipe(up_reader, writer))

    return await asyncio.start_server(client, "127.0.0.1", 0)


async def test_a_slow_device_server_shows_in_the_measured_busy_time() -> None:
    sim = build_loop(["1"], clock=SimClock(1.0))
    server = await serve_tcp(sim, "127.0.0.1", 0)
    proxy = await _slow_proxy(server.sockets[0].getsockname()[1])
    port = proxy.sockets[0].getsockname()[1]
    config = parse_config({"loops": [{
        "name": "main", "port": f"socket://127.0.0.1:{port}", "controllers": [{"body": "1"}],
        "timeouts": {"host_latency": 0.5}, "poll": {"idle_period": 600, "sensor_period": 3600,
                                                    "condition_period": 3600}}]})  # fmt: skip
    gateway = Runtime(config, transports=open_lines(config))
    metrics = Metrics(gateway)
    try:
        await gateway.start()
        scheduler = gateway.schedulers["main"]
        for _ in range(10):
            assert (await scheduler.submit("1", parse("V"))).ok
        fams = parse_exposition(metrics.render())
    finally:
        await gateway.close()
        proxy.close()
        server.close()
        sim.close()
    busy = value(fams, "rc233_loop_busy_seconds_total", loop="main")
    wire = value(fams, "rc233_loop_wire_seconds_total", loop="main")
    transactions = sum(v for k, v in fams["rc233_loop_transactions_total"].samples.items())
    assert transactions >= 10
    # each transaction waited at least 2 x DELAY more than its bytes take on the wire
    assert busy - wire >= transactions * 2 * DELAY * 0.9, (busy, wire, transactions)
    print(f"\n{transactions:.0f} transactions: wire {wire:.3f} s, measured busy {busy:.3f} s")
