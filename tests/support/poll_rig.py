"""The poller's rig: the real scheduler and state cache on the in-process simulator.

``start_rig`` builds a simulated loop, a ``LoopScheduler`` on it through ``PipeTransport``, a
state cache and a poller attached to both; ``Rig`` reads what a user would notice: the frames
on the simulated line (its log, in simulated seconds) and the state the cache shows. Waiting
is always on a condition (state changes, line records), never on a sleep.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass
from itertools import pairwise

from gateway.bus.config import LoopConfig
from gateway.bus.poller import PollConfig, Poller, attach
from gateway.bus.requests import Priority
from gateway.bus.scheduler import LoopScheduler
from gateway.bus.state import StateCache
from gateway.protocol.command_text import parse
from gateway.sim.cli import build_loop
from gateway.sim.clock import LineRecord, RecordKind, SimClock
from gateway.sim.control import Controls
from gateway.sim.loop import SimLoop
from gateway.sim.serve import SimPort
from gateway.transport.pipe import PipeTransport
from tests.support.state_waits import until_state

LOOP = "L"
#: A gap between a moving controller's status reads this long means one was skipped (two
#: periods); shorter ones are the host's (the real-time tests run beside other work).
SKIPPED = 2 * PollConfig().moving_period
ALL_BODIES = "0123456789ABCDE"  # 15 controllers: the most one '$' loop holds (§3-III)


@dataclass
class Rig:
    """A simulated loop, its scheduler, the state cache and the poller."""

    sim: SimLoop
    scheduler: LoopScheduler
    state: StateCache
    poller: Poller
    ports: list[SimPort]

    @property
    def controls(self) -> Controls:
        return Controls(self.sim)

    async def until(self, check: Callable[[], bool], timeout: float = 20.0) -> None:
        """Wait (real seconds) until ``check()`` holds, re-checked on every state change."""
        await until_state(self.state, check, timeout)

    async def identified(self, bodies: str, timeout: float = 30.0) -> None:
        """Wait until every controller of ``bodies`` was read through, framing included."""
        await self.until(lambda: all(self.frames(f"${b}EL\r".encode()) for b in bodies), timeout)

    async def sim_time(self, t: float, timeout: float = 20.0) -> None:
        """Wait until the simulated line has passed time ``t`` (the poller keeps it busy)."""
        await self.sim.log.wait_for(lambda r: r.time >= t, self.sim.log.next_seq, timeout)

    def frames(self, text: bytes, since: float = 0.0) -> list[LineRecord]:
        """The frames ``text`` the controllers heard from simulated time ``since`` on."""
        return [
            r
            for r in self.sim.log.since(0)
            if r.kind is RecordKind.HEARD and r.data == text and r.time >= since
        ]

    def frames_in(self, start: float, end: float) -> list[LineRecord]:
        """Every frame the controllers heard in [start, end)."""
        return [
            r for r in self.sim.log.since(0) if r.kind is RecordKind.HEARD and start <= r.time < end
        ]

    def assert_probed_with_backoff(self, body: str, since: float) -> None:
        """Offline from ``since``, ``body`` was probed with backoff (0.4, 0.8, 1.6, 2.0 s:
        ``probe_initial=0.4, probe_max=2.0``), not polled at the idle rate."""
        probes = [f.time for f in self.frames(f"${body}\r".encode(), since=since)]
        gaps = [b - a for a, b in pairwise(probes)]
        assert 2 <= len(probes) <= 5, probes
        assert gaps == sorted(gaps) and gaps[0] >= 0.4, gaps

    def answered(self, text: bytes, start: float, end: float) -> list[LineRecord]:
        """Replies that reached the host in [start, end) to frames ``text``."""
        refs = {r.ref for r in self.frames(text)}
        return [
            r
            for r in self.sim.log.since(0)
            if r.kind is RecordKind.REPLY and r.ref in refs and start <= r.time < end
        ]


#: Attaches a poller to a scheduler and its state cache (``attach``, or another order).
WirePoller = Callable[[LoopScheduler, StateCache], Poller]


async def start_rig(made: list[Rig], bodies: str, scale: float, wire: WirePoller) -> Rig:
    """A simulated loop of ``bodies``, a scheduler on it, a state cache and the poller ``wire``
    attaches, started; kept in ``made`` for ``close_rigs``."""
    sim = build_loop(list(bodies), clock=SimClock(scale))
    ports: list[SimPort] = []

    def connect() -> SimPort:
        ports.append(SimPort(sim))
        return ports[-1]

    scheduler = LoopScheduler(
        PipeTransport(connect, url="pipe://sim"), LoopConfig(name=LOOP, time_scale=scale)
    )
    state = StateCache()
    poller = wire(scheduler, state)
    r = Rig(sim, scheduler, state, poller, ports)
    made.append(r)
    await scheduler.start()
    poller.start()
    return r


async def close_rigs(made: list[Rig]) -> None:
    for r in made:
        await r.poller.stop()
        await r.scheduler.close()
        r.sim.close()


async def move(r: Rig, body: str, motor: int, target: int) -> None:
    """Set the position data and start an absolute move (§10 2, §10 3 with a motor suffix)."""
    result = await r.scheduler.submit(
        body, [parse(f"2{target}"), parse(f"3{motor}")], priority=Priority.OPERATOR
    )
    assert result.ok, result


#: ``await make(bodies, scale=..., **poll_config)``: a rig whose poller polls ``bodies``.
MakeRig = Callable[..., Awaitable[Rig]]


@asynccontextmanager
async def poller_rigs(default_scale: float) -> AsyncIterator[MakeRig]:
    """Rigs whose poller polls their bodies with the poll settings given (``PollConfig``),
    at ``default_scale`` unless a test says; every rig made is closed at the end."""
    made: list[Rig] = []

    async def make(bodies: str = "12", scale: float = default_scale, **config: float) -> Rig:
        def wire(scheduler: LoopScheduler, state: StateCache) -> Poller:
            return attach(scheduler, state, list(bodies), PollConfig(**config))

        return await start_rig(made, bodies, scale, wire)

    try:
        yield make
    finally:
        await close_rigs(made)
