"""``Runtime`` over line workers: its schedulers are the workers' proxies, its state the
mirror, and service/ reads of them what it reads of a scheduler in one process: the line's
rate, its adapter, the time scale, the trace (switched in the worker, its records here), and
a poller it stops and starts. Real processes: ``rc233-gateway sim --tcp`` and the worker.
"""

from __future__ import annotations

import asyncio
import re
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from gateway.bus.events import BusEvent, TransactionDone, TransactionsTallied
from gateway.bus.lifecycle import LinkState
from gateway.bus.requests import Priority
from gateway.bus.trace import FrameDirection
from gateway.engine.proxy import SchedulerProxy
from gateway.protocol.command_text import parse
from gateway.service.config import parse_config
from gateway.service.runtime.runtime import Runtime
from tests.support.restart_rig import WAIT, RestartRig
from tests.support.state_waits import until_state

SCALE = 2.0


@pytest.fixture
async def runtime(tmp_path: Path) -> AsyncIterator[Runtime]:
    rig = RestartRig(tmp_path, SCALE)
    await rig.start_sim()
    found = re.search(r'port = "(socket://[^"]+)"', rig.config.read_text("utf-8"))
    assert found
    config = parse_config(
        {"loops": [{"name": "main", "port": found[1], "controllers": [{"body": "1"}]}]}
    )
    gateway = Runtime(config, time_scale=SCALE)
    try:
        await gateway.start()
        yield gateway
    finally:
        await gateway.close()
        await rig.close()


async def test_the_runtime_reads_a_workers_loop_as_a_scheduler(runtime: Runtime) -> None:
    assert runtime.workers is not None and runtime.state is runtime.workers.mirror
    scheduler = runtime.scheduler("main")
    assert isinstance(scheduler, SchedulerProxy)  # the loop runs in a worker, not here
    await until_state(runtime.state, lambda: scheduler.state is LinkState.UP, WAIT)
    assert scheduler.timing.baud == 9600 and scheduler.transport.adapter is None
    assert runtime.device_seconds("main") == SCALE

    scheduler.trace.enable(True)
    result = await scheduler.submit("1", parse("A005D"))
    assert result.ok
    sent = [r for r in scheduler.trace.records("1") if r.direction is FrameDirection.TX]
    assert b"$1A005D\r" in [r.data for r in sent]
    scheduler.trace.enable(False)
    scheduler.trace.clear()
    await scheduler.submit("1", parse("A005D"))
    assert scheduler.trace.records() == []


async def test_a_stopped_poller_sends_nothing_until_started(runtime: Runtime) -> None:
    scheduler = runtime.scheduler("main")
    await until_state(runtime.state, lambda: scheduler.state is LinkState.UP, WAIT)
    await runtime.pollers["main"].stop()
    # the poll in flight when it stopped ends first (abandoned, not cut): then only ours
    await scheduler.submit("1", parse("A005D"))
    before = runtime.loop_counters("main").transactions
    await scheduler.submit("1", parse("A005D"))
    await scheduler.submit("1", parse("A005D"))
    assert runtime.loop_counters("main").transactions == before + 2  # the requests alone
    polled = asyncio.Event()

    def note(e: BusEvent) -> None:  # an unfollowed controller's polls cross in the tally
        alone = isinstance(e, TransactionDone) and e.priority is Priority.POLL
        if alone or (isinstance(e, TransactionsTallied) and e.tallies):
            polled.set()

    scheduler.events.subscribe(note)
    runtime.pollers["main"].start()
    await asyncio.wait_for(polled.wait(), WAIT)
