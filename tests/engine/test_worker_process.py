"""A line worker in a process of its own, killed while its axis moves: the loop is down with
the cause meanwhile, the worker comes back after its back-off, and what the axis does is
read back from the device, never carried over from the dead worker.

Real processes: ``rc233-gateway sim --tcp`` (``RestartRig``) outlives the worker; the worker
is ``python -m gateway.engine.process``, started and restarted by a ``WorkerSupervisor``.
"""

from __future__ import annotations

import asyncio
import os
import re
import signal
from pathlib import Path

import pytest

from gateway.bus.config import LoopConfig
from gateway.bus.events import BusEvent, LinkDown, LinkUp
from gateway.bus.lifecycle import LinkState
from gateway.bus.poll_plan import PollConfig
from gateway.bus.requests import LoopDown
from gateway.engine.mirror import StateMirror
from gateway.engine.proxy import WorkerClient
from gateway.engine.supervisor import WorkerSupervisor
from gateway.engine.worker_spec import LoopSpec
from gateway.protocol.command_text import parse
from tests.support.restart_rig import WAIT, RestartRig
from tests.support.state_waits import until_state

SCALE = 1.0
#: Real seconds between a worker's death and its next start, in this test.
BACKOFF = 0.3


async def _until_event(
    events: list[BusEvent], seen: asyncio.Event, kind: type, says: str = ""
) -> BusEvent:
    """The first event of ``kind`` (whose cause has ``says``), once it came."""

    def match(e: BusEvent) -> bool:
        return isinstance(e, kind) and says in getattr(e, "cause", "")

    async with asyncio.timeout(WAIT):
        while not any(match(e) for e in events):
            seen.clear()
            await seen.wait()
    return next(e for e in events if match(e))


async def _sim(tmp_path: Path, loop: str) -> tuple[RestartRig, LoopSpec]:
    """A simulated loop in a process of its own, and the worker's spec of it."""
    rig = RestartRig(tmp_path, SCALE)
    await rig.start_sim()
    found = re.search(r'port = "(socket://[^"]+)"', rig.config.read_text("utf-8"))
    assert found
    config = LoopConfig(name=loop, time_scale=SCALE)
    return rig, LoopSpec(config, PollConfig(), ("1",), found[1], 9600)


async def test_a_killed_worker_is_restarted_and_its_moving_axis_is_read_back(
    tmp_path: Path,
) -> None:
    rig, spec = await _sim(tmp_path, "main")
    mirror = StateMirror()
    client = WorkerClient("w1", ["main"], mirror)
    supervisor = WorkerSupervisor(client, [spec], backoff=(BACKOFF,))
    proxy = client.proxies["main"]
    events: list[BusEvent] = []
    seen = asyncio.Event()

    def note(event: BusEvent) -> None:
        events.append(event)
        seen.set()

    proxy.events.subscribe(note)
    try:
        await asyncio.wait_for(supervisor.start(), WAIT)
        await until_state(mirror, lambda: proxy.state is LinkState.UP, WAIT)
        assert supervisor.process is not None
        first_pid = supervisor.process.pid
        await proxy.submit("1", parse("7"), motor=1)  # jog motor 1: it moves until a stop
        await until_state(mirror, lambda: mirror.controller("main", "1").moving is True, WAIT)
        events.clear()

        os.kill(first_pid, signal.SIGKILL)
        down = await _until_event(events, seen, LinkDown, "was killed by SIGKILL")
        assert isinstance(down, LinkDown) and down.retry_after == BACKOFF
        assert proxy.state is LinkState.DOWN and "restarting in 0.3 s" in proxy.cause
        with pytest.raises(LoopDown) as refused:
            await proxy.submit("1", parse(""))
        assert "killed by SIGKILL" in str(refused.value)
        assert refused.value.retry_after == BACKOFF
        assert (await rig.axis("1", 1))["moving"]  # the machine goes on meanwhile
        assert mirror.controller("main", "1").moving is None  # but nobody reads it now
        assert mirror.axis("main", "1", 1).stale and not mirror.loop("main").up

        # The mirror forgets the dead worker's picture: the new worker reads the device.
        await _until_event(events, seen, LinkUp)
        assert supervisor.restarts == 1
        assert supervisor.process is not None and supervisor.process.pid != first_pid
        await until_state(
            mirror,
            lambda: mirror.source_seq("w1") is not None and proxy.state is LinkState.UP,
            WAIT,
        )
        await until_state(mirror, lambda: mirror.controller("main", "1").moving is True, WAIT)
        stop = await proxy.stop("1", parse("S"))
        assert stop.ok
        await until_state(mirror, lambda: mirror.controller("main", "1").moving is False, WAIT)
        assert await rig.heard("$1S") == 1
    finally:
        await supervisor.close()
        await rig.close()


async def test_the_other_worker_goes_on_while_one_is_dead(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    rig_a, spec_a = await _sim(tmp_path / "a", "a")
    rig_b, spec_b = await _sim(tmp_path / "b", "b")
    mirror = StateMirror()  # one mirror, fed by both workers
    a = WorkerSupervisor(WorkerClient("wa", ["a"], mirror), [spec_a], backoff=(60.0,))
    b = WorkerSupervisor(WorkerClient("wb", ["b"], mirror), [spec_b], backoff=(60.0,))
    proxy_a, proxy_b = a.client.proxies["a"], b.client.proxies["b"]
    try:
        await asyncio.wait_for(asyncio.gather(a.start(), b.start()), WAIT)
        both_up = lambda: proxy_a.state is LinkState.UP and proxy_b.state is LinkState.UP  # noqa: E731
        await until_state(mirror, both_up, WAIT)
        assert a.process is not None
        a.process.kill()
        # the channel closes first, then the supervisor learns how the worker ended
        await until_state(mirror, lambda: "restarting in" in (mirror.loop("a").cause or ""), WAIT)
        assert not mirror.loop("a").up and "was killed by SIGKILL" in proxy_a.cause
        with pytest.raises(LoopDown) as refused:
            await proxy_a.submit("1", parse(""))
        assert refused.value.retry_after == 60.0  # the back-off: when to ask again
        # Loop b, in its own worker, answers as before, and its state still flows.
        result = await proxy_b.submit("1", [parse("A0051234"), parse("A005D")])
        assert result.value == 1234 and proxy_b.state is LinkState.UP
        await proxy_b.submit("1", parse("7"), motor=1)
        await until_state(mirror, lambda: mirror.controller("b", "1").moving is True, WAIT)
        assert mirror.loop("b").up and proxy_a.state is LinkState.DOWN
        await proxy_b.stop("1")
    finally:
        await asyncio.gather(a.close(), b.close())
        await asyncio.gather(rig_a.close(), rig_b.close())
