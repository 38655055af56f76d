"""One log line per state change (gateway.service.runtime.state_log), never one per poll.

A simulated loop behind the gateway's real serial path: a controller switched off goes
offline in one WARNING line and comes back in one INFO line however many polls it misses;
'?' replies injected on the line are summarised in one line per period; the loop's own
down/up events give one line each.
"""

from __future__ import annotations

import asyncio
import json
import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from dataclasses import dataclass

from gateway.bus.events import LinkDown, LinkUp
from gateway.cli.logs import JsonFormatter
from gateway.service.runtime.runtime import Runtime
from gateway.service.runtime.simulated import SIM_LOOP, simulated_config
from gateway.service.runtime.state_log import StateLog
from gateway.sim.cli import build_loop
from gateway.sim.clock import SimClock
from gateway.sim.control import Controls
from gateway.sim.serve import SimPort
from gateway.transport.pipe import PipeTransport
from tests.support.state_waits import until_state

SCALE = 50.0
WAIT = 20.0


class Recorder(logging.Handler):
    """The records of ``gateway.state`` (and the scheduler's), each one waking ``wait_for``."""

    def __init__(self) -> None:
        super().__init__(logging.INFO)
        self.records: list[logging.LogRecord] = []
        self.changed = asyncio.Event()

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)
        self.changed.set()

    def events(self, name: str) -> list[logging.LogRecord]:
        return [r for r in self.records if getattr(r, "event", None) == name]

    async def wait_for(self, name: str, count: int = 1) -> list[logging.LogRecord]:
        async with asyncio.timeout(WAIT):
            while len(self.events(name)) < count:
                self.changed.clear()
                await self.changed.wait()
        return self.events(name)


@dataclass
class Running:
    runtime: Runtime
    controls: Controls
    log: Recorder
    now: list[float]


@asynccontextmanager
async def running(summary_period: float = 60.0) -> AsyncIterator[Running]:
    sim = build_loop(["1", "2"], clock=SimClock(SCALE))
    runtime = Runtime(
        simulated_config(["1", "2"]),
        transports={SIM_LOOP: PipeTransport(lambda: SimPort(sim))},
        time_scale=SCALE,
    )
    now = [1000.0]
    state_log = StateLog(runtime, summary_period=summary_period, clock=lambda: now[0])
    recorder = Recorder()
    logger = logging.getLogger("gateway.state")
    logger.addHandler(recorder)
    logger.setLevel(logging.INFO)
    state_log.start()
    try:
        await runtime.start()
        yield Running(runtime, Controls(sim), recorder, now)
    finally:
        state_log.stop()
        logger.removeHandler(recorder)
        await runtime.close()
        sim.close()


async def test_a_controller_switched_off_is_one_line_down_and_one_line_back() -> None:
    async with running() as run:
        online = await run.log.wait_for("controller_online", 2)
        assert sorted(r.getMessage() for r in online) == [
            "controller sim.1 online", "controller sim.2 online",
        ]  # fmt: skip
        state = run.runtime.state
        run.controls.power("2", on=False)
        await until_state(state, lambda: state.controller(SIM_LOOP, "2").online is False, WAIT)
        (offline,) = await run.log.wait_for("controller_offline")
        assert offline.levelno == logging.WARNING
        assert offline.getMessage() == "controller sim.2 offline: it does not answer"
        assert (offline.loop, offline.controller) == ("sim", "sim.2")  # type: ignore[attr-defined]
        # Many polls of the silent controller later: still one line.
        polls = run.runtime.loop_counters(SIM_LOOP).transactions
        await until_state(
            state, lambda: run.runtime.loop_counters(SIM_LOOP).transactions > polls + 10, WAIT
        )
        assert len(run.log.events("controller_offline")) == 1
        run.controls.power("2", on=True)
        online = await run.log.wait_for("controller_online", 3)
        assert online[-1].getMessage() == "controller sim.2 online again"
        assert online[-1].levelno == logging.INFO
        assert len(run.log.events("controller_offline")) == 1


async def test_line_faults_are_summarised_once_a_period() -> None:
    async with running(summary_period=60.0) as run:
        await run.log.wait_for("controller_online", 2)
        run.controls.fault("nak", shots=3)
        state = run.runtime.state
        await until_state(state, lambda: run.runtime.loop_counters(SIM_LOOP).naks >= 3, WAIT)
        assert run.log.events("line_faults") == []  # the period has not passed
        run.now[0] += 60.0
        (summary,) = await run.log.wait_for("line_faults")
        assert summary.levelno == logging.WARNING
        assert summary.faults["naks"] == 3 and summary.faults["retries"] >= 3  # type: ignore[attr-defined]
        assert "3 '?' replies" in summary.getMessage()
        # Another period with no fault: no line.
        run.now[0] += 60.0
        transactions = run.runtime.loop_counters(SIM_LOOP).transactions
        await until_state(
            state, lambda: run.runtime.loop_counters(SIM_LOOP).transactions > transactions + 3, WAIT
        )
        assert len(run.log.events("line_faults")) == 1


async def test_loop_up_again_names_how_long_it_was_down() -> None:
    async with running() as run:
        (first,) = await run.log.wait_for("loop_up")
        assert first.getMessage() == "loop sim up"
        events = run.runtime.schedulers[SIM_LOOP].events
        events.publish(LinkDown(loop=SIM_LOOP, cause="no answer from any controller"))
        run.now[0] += 12.5
        events.publish(LinkDown(loop=SIM_LOOP, cause="cannot open the port"))  # a retry
        events.publish(LinkUp(loop=SIM_LOOP))
        up = run.log.events("loop_up")
        assert [r.getMessage() for r in up] == [
            "loop sim up", "loop sim up again after 12.5 s down (cannot open the port)",
        ]  # fmt: skip
        line = json.loads(JsonFormatter().format(up[-1]))
        assert {k: line[k] for k in ("level", "logger", "event", "loop", "down_seconds")} == {
            "level": "INFO", "logger": "gateway.state", "event": "loop_up", "loop": "sim",
            "down_seconds": 12.5,
        }  # fmt: skip
