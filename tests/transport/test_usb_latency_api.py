"""What the gateway reports about a loop's adapter: ``GET /loops/{loop}`` and ``/metrics``.

The loop is served by ``rc233-gateway sim --pty`` in its own process and opened by the
gateway's ``SerialLine``, as at a site. With the real /sys the pseudo-terminal has no
usb-serial entry: nothing to warn about, and no error. With a sysfs tree of the test's own
that gives the tty a 16 ms latency timer (an FTDI adapter's default), every face says so.
"""

from __future__ import annotations

import logging
import os
from collections.abc import AsyncIterator, Callable
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from pathlib import Path

import httpx
import pytest

from gateway.api.app import create_app
from gateway.api.security import AuthConfig
from gateway.bus.state import StateCache
from gateway.compose import compose
from gateway.service.config import load_config
from gateway.service.feed import Feed
from gateway.service.runtime.runtime import Runtime
from gateway.service.runtime.simulated import simulated_config
from gateway.service.topology import Topology
from gateway.transport import SerialLine
from gateway.transport.usb_latency import SYSFS_ROOT, AdapterReport
from tests.support.sim_process import sim_on_pty
from tests.support.ws_server import check_server_message

SCALE = 20.0
CELL = """
[[loops]]
name = "bench"
port = "{port}"
[loops.poll]
idle_period = 0.5

[[loops.controllers]]
body = "1"
"""

Gateway = Callable[[Callable[[str], Path]], AbstractAsyncContextManager[httpx.AsyncClient]]


@pytest.fixture
def gateway(tmp_path: Path) -> Gateway:
    """A gateway on a ``sim --pty`` loop whose line reads its adapter's sysfs at
    ``sysfs(tty_path)``."""

    @asynccontextmanager
    async def run(sysfs: Callable[[str], Path]) -> AsyncIterator[httpx.AsyncClient]:
        async with sim_on_pty(tmp_path, "--bodies", "1", "--time-scale", str(SCALE)) as port:
            cell = tmp_path / "cell.toml"
            cell.write_text(CELL.format(port=port))
            config = load_config(cell)
            line = SerialLine(port, 9600, sysfs_root=sysfs(port))
            runtime = Runtime(config, transports={"bench": line}, time_scale=SCALE)
            app = create_app(compose(runtime), auth=AuthConfig(no_auth=True))
            async with app.router.lifespan_context(app):
                transport = httpx.ASGITransport(app=app)
                base = "http://localhost"
                async with httpx.AsyncClient(transport=transport, base_url=base, timeout=30) as c:
                    yield c

    return run


def samples(metrics: str, family: str) -> list[str]:
    return [line for line in metrics.splitlines() if line.startswith(family + "{")]


async def test_a_pseudo_terminal_shows_no_warning_and_no_error(
    gateway: Gateway, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO)
    async with gateway(lambda _: SYSFS_ROOT) as client:
        view = (await client.get("/api/v1/loops/bench")).json()
        assert view["up"] is True
        adapter = view["adapter"]
        assert adapter["low_latency"] is False  # a pty refuses the flag: information only
        assert (adapter["latency_timer_ms"], adapter["warning"]) == (None, None)
        metrics = (await client.get("/metrics")).text
    assert samples(metrics, "rc233_loop_adapter_slow") == [
        'rc233_loop_adapter_slow{loop="bench"} 0'
    ]
    assert samples(metrics, "rc233_loop_adapter_latency_timer_seconds") == []
    loud = [r for r in caplog.records
            if r.name.startswith("gateway.transport") and r.levelno >= logging.WARNING]  # fmt: skip
    assert loud == [], [r.getMessage() for r in loud]


async def test_a_sixteen_ms_timer_shows_in_the_view_the_metrics_and_the_log(
    gateway: Gateway, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    def slow_sysfs(port: str) -> Path:
        tty = os.path.basename(os.path.realpath(port))
        device = tmp_path / "sys" / "bus" / "usb-serial" / "devices" / tty
        device.mkdir(parents=True)
        (device / "latency_timer").write_text("16\n")
        return tmp_path / "sys"

    async with gateway(slow_sysfs) as client:
        view = (await client.get("/api/v1/loops/bench")).json()
        assert view["up"] is True  # slow, but working
        adapter = view["adapter"]
        assert adapter["latency_timer_ms"] == 16
        assert "16 ms" in adapter["warning"] and "99-rc233-ftdi-latency.rules" in adapter["warning"]
        metrics = (await client.get("/metrics")).text
    assert samples(metrics, "rc233_loop_adapter_slow") == [
        'rc233_loop_adapter_slow{loop="bench"} 1'
    ]
    assert samples(metrics, "rc233_loop_adapter_latency_timer_seconds") == [
        'rc233_loop_adapter_latency_timer_seconds{loop="bench"} 0.016'
    ]
    warned = [r.getMessage() for r in caplog.records
              if r.name == "gateway.transport" and r.levelno == logging.WARNING]  # fmt: skip
    assert len(warned) == 1 and "latency timer is 16 ms" in warned[0], warned


def test_the_loop_topic_of_the_websocket_feed_carries_the_adapter() -> None:
    """The feed takes the report from the loop's line (``loop_adapter``, as compose wires
    it): a subscriber's snapshot of the loop shows the slow timer, in the published schema."""
    report = AdapterReport(tty="ttyUSB0", low_latency=False, latency_timer_ms=16)
    topology = Topology(simulated_config(("1",)))
    feed = Feed(topology, StateCache(), loop_adapter={"sim": report}.get)
    client = feed.subscribe(["loop:sim"])
    snapshot = check_server_message(client.get_nowait() or "")
    [loop] = snapshot["loops"]
    adapter = loop["adapter"]
    assert adapter["tty"] == "ttyUSB0" and adapter["latency_timer_ms"] == 16
    assert "16 ms" in adapter["warning"]
