"""Fixtures of the bus tests: a loop scheduler on the in-process simulator.

``make_bus(bodies="1", scale=SCALE, baud=9600, faults=None, **config)`` builds a simulated loop
(``gateway.sim.cli.build_loop``) and a ``LoopScheduler`` on it through the transport layer's
``PipeTransport`` (the real serial code path of the gateway, minus the OS), both running
``scale`` times faster than real time, and returns a ``Bus`` holding both. Everything is closed
after the test. No test sleeps to synchronise: they wait on results, events and the simulator's
line log (``LineLog.wait_for``) with time-outs.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

import pytest

from gateway.bus.config import LoopConfig
from gateway.bus.events import BusEvent, ReplyObserved
from gateway.bus.scheduler import LoopScheduler
from gateway.protocol.command_text import parse
from gateway.protocol.framing import BAUD_RATES, Series
from gateway.sim.cli import build_loop
from gateway.sim.clock import LineRecord, RecordKind, SimClock
from gateway.sim.faults import FaultKind, FaultRule, Faults
from gateway.sim.loop import SimLoop
from gateway.sim.memory import Baud
from gateway.sim.serve import SimPort
from gateway.transport.pipe import PipeTransport

#: Device seconds per real second in the bus tests.
SCALE = 100.0
#: Real seconds of host latency the tests' schedulers allow (event-loop jitter under load).
HOST_LATENCY = 0.02


@dataclass
class Bus:
    """A scheduler and the simulated loop it drives."""

    sim: SimLoop
    scheduler: LoopScheduler
    transport: PipeTransport
    events: list[BusEvent] = field(default_factory=list)
    ports: list[SimPort] = field(default_factory=list)
    unplugged: bool = False

    def connect(self) -> SimPort:
        """The transport's peer factory: a new port on the loop, unless unplugged."""
        if self.unplugged:
            raise OSError("the cable is unplugged")
        port = SimPort(self.sim)
        self.ports.append(port)
        return port

    def unplug(self) -> None:
        """Pull the cable: the port closes and cannot be opened again until ``plug``."""
        self.unplugged = True
        self.ports[-1].close()

    def plug(self) -> None:
        """Put the cable back."""
        self.unplugged = False

    def frames(self, body: str | None = None) -> list[bytes]:
        """Every command frame the simulator heard (of ``body``), in order."""
        return [
            r.data
            for r in self.sim.log.since(0)
            if r.kind is RecordKind.HEARD and r.ref > 0 and (body is None or r.body == body)
        ]

    def texts(self, body: str = "1") -> list[str]:
        """The command texts the simulator heard for ``body`` ('$1OH4000\\r' -> 'OH4000')."""
        return [f[2:].rstrip(b"\r").decode("latin-1") for f in self.frames(body)]

    def records(self, kind: RecordKind | None = None) -> list[LineRecord]:
        """The simulator's line log (of one kind)."""
        return [r for r in self.sim.log.since(0) if kind is None or r.kind is kind]

    def fault(self, kind: FaultKind, *, shots: int = 1, body: str | None = None, **kw: Any) -> None:
        """Arm a one-shot line fault on the simulator."""
        self.sim.faults.add(FaultRule(kind, shots=shots, body=body, **kw))

    def controller(self, body: str = "1") -> Any:
        """The simulated controller at ``body``."""
        return self.sim.unit(body).device

    async def query(self, body: str, text: str, **kw: Any) -> Any:
        """Submit one query and return its value."""
        result = await self.scheduler.submit(body, parse(text), **kw)
        return result.value

    def once_after(self, wire: str, action: Callable[[], None], nth: int = 1) -> None:
        """Run ``action`` right after the ``nth`` published reply to the command ``wire``
        (the scheduler reads a motion's position twice before it: ``nth=2``). It hears the
        reply as the state cache does, before the scheduler writes its next frame (``urgent``):
        a fault armed here hits that frame."""
        fired: list[bool] = []

        def watch(event: BusEvent) -> None:
            if isinstance(event, ReplyObserved) and event.command.wire() == wire:
                fired.append(True)
                if len(fired) == nth:
                    action()

        self.scheduler.events.subscribe(watch, urgent=True)

    async def wait_idle(self, body: str = "1", limit: int = 2000) -> None:
        """Poll ``""`` through the scheduler until bit 0 (moving) is 0 (§13-2 CHECK)."""
        for _ in range(limit):
            status = await self.query(body, "")
            if status is not None and not status.moving:
                return
        raise AssertionError(f"body {body} still moving")

    def position(self, body: str = "1", motor: int = 1) -> int:
        """The simulated motor's position counter now."""
        now = self.sim.now()
        return int(self.controller(body).snapshot(now)["axes"][str(motor)]["position"])


MakeBus = Callable[..., Awaitable[Bus]]


@pytest.fixture
async def make_bus() -> AsyncIterator[MakeBus]:
    """``await make_bus(bodies="1", scale=SCALE, baud=9600, faults=None, **LoopConfig)``."""
    made: list[Bus] = []

    async def make(
        bodies: str = "1",
        *,
        scale: float = SCALE,
        baud: int = 9600,
        sim_baud: int | None = None,
        faults: Faults | None = None,
        series: Series = Series.DOLLAR,
        **config: Any,
    ) -> Bus:
        sim = build_loop(
            list(bodies),
            series=series,
            clock=SimClock(scale),
            baud=sim_baud or baud,
            faults=faults or Faults(seed=1),
        )
        # The controllers at the line's rate, as if set with ES and powered on (§10 ES).
        for unit in sim.units:
            unit.device.baud = Baud(BAUD_RATES.index(sim_baud or baud))
        holder: list[Bus] = []
        transport = PipeTransport(lambda: holder[0].connect(), url="pipe://sim", baud=baud)
        config.setdefault("host_latency", HOST_LATENCY)
        scheduler = LoopScheduler(transport, LoopConfig(time_scale=scale, **config))
        bus = Bus(sim, scheduler, transport)
        holder.append(bus)
        scheduler.events.subscribe(bus.events.append)
        made.append(bus)
        await scheduler.start()
        return bus

    yield make
    for bus in made:
        await bus.scheduler.close()
        bus.sim.close()
