"""The port disappears and comes back, over the real serial path.

The simulator is served on a pseudo-terminal (as `rc233-gateway sim --pty` serves it) or over
TCP (as a serial device server would), and the scheduler talks to it through
pyserial-asyncio-fast (``SerialLine``). The pty is closed and a new one takes its place behind
the same path (as a /dev/serial/by-id link does when a USB adapter is plugged in again); the TCP
server is stopped and started again on the same port. Each time the loop goes down, callers get
a clear ``LoopDown`` at once, and the loop comes back by itself and answers again.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from gateway.bus.config import LoopConfig
from gateway.bus.events import BusEvent, LinkDown, LinkUp
from gateway.bus.requests import LoopDown
from gateway.bus.scheduler import LinkState, LoopScheduler
from gateway.protocol.command_text import parse
from gateway.sim.cli import build_loop
from gateway.sim.clock import SimClock
from gateway.sim.loop import SimLoop
from gateway.sim.serve import PtyLine, serve_tcp
from gateway.transport.serial_line import SerialLine
from tests.support.bus_rig import HOST_LATENCY, SCALE


def _config() -> LoopConfig:
    return LoopConfig(
        time_scale=SCALE,
        host_latency=HOST_LATENCY,
        reconnect_initial_real=0.02,
        reconnect_max_real=0.1,
    )


def _next(scheduler: LoopScheduler, kind: type[BusEvent]) -> asyncio.Event:
    seen = asyncio.Event()
    scheduler.events.subscribe(lambda e: seen.set() if isinstance(e, kind) else None)
    return seen


async def _down_fast(scheduler: LoopScheduler) -> None:
    loop = asyncio.get_running_loop()
    started = loop.time()
    with pytest.raises(LoopDown) as caught:
        await scheduler.submit("1", parse("OH"))
    assert loop.time() - started < 0.05  # at once, not after a time-out
    assert "is down" in str(caught.value) and caught.value.retry_after is not None


@pytest.fixture
async def sim() -> AsyncIterator[SimLoop]:
    loop = build_loop(["1"], clock=SimClock(SCALE))
    yield loop
    loop.close()


async def test_pty_closed_and_reopened(sim: SimLoop, tmp_path: Path) -> None:
    link = tmp_path / "ttyRC233"
    ptys = [PtyLine(sim)]
    link.symlink_to(ptys[0].start())
    scheduler = LoopScheduler(SerialLine(str(link), 9600), _config())
    await scheduler.start()
    try:
        assert (await scheduler.submit("1", parse("OH"))).value == 5000
        down, up = _next(scheduler, LinkDown), _next(scheduler, LinkUp)
        ptys[0].close()
        await asyncio.wait_for(down.wait(), 5)
        assert scheduler.state is LinkState.DOWN
        await _down_fast(scheduler)
        ptys.append(PtyLine(sim))
        link.unlink()
        link.symlink_to(ptys[1].start())
        await asyncio.wait_for(up.wait(), 5)
        assert (await scheduler.submit("1", parse("OH"))).value == 5000
    finally:
        await scheduler.close()
        for pty in ptys:
            pty.close()


async def test_tcp_device_server_restarted(sim: SimLoop) -> None:
    server = await serve_tcp(sim, "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    scheduler = LoopScheduler(SerialLine(f"socket://127.0.0.1:{port}", 9600), _config())
    await scheduler.start()
    try:
        assert (await scheduler.submit("1", parse("OH"))).value == 5000
        down, up = _next(scheduler, LinkDown), _next(scheduler, LinkUp)
        server.close()
        sim.drop_host()  # the device server drops its client as it goes
        await server.wait_closed()
        await asyncio.wait_for(down.wait(), 5)
        await _down_fast(scheduler)
        server = await serve_tcp(sim, "127.0.0.1", port)
        await asyncio.wait_for(up.wait(), 5)
        assert (await scheduler.submit("1", parse("OH"))).value == 5000
    finally:
        await scheduler.close()
        server.close()
        await server.wait_closed()
