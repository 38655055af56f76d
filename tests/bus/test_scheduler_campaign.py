"""The scheduler's fault campaign: concurrent callers over 3 controllers x 2 motors, with 5 %
'?', 2 % dropped and 1 % garbled replies injected by the simulator.

Every caller gets an answer, and every motor ends where the moves the scheduler reported imply:
a DONE move ran exactly once, a NOT_DONE move did not run, an UNKNOWN one may have (the
caller was told). The campaign runs twice: 2,000 commands over the in-process pipe, and a
shorter one over the real serial path (pyserial-asyncio-fast on a pseudo-terminal served by the
simulator, as `rc233-gateway sim --pty` serves it).
"""

from __future__ import annotations

import asyncio
import itertools
import random
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass, field

import pytest

from gateway.bus.config import LoopConfig
from gateway.bus.requests import Outcome, Priority
from gateway.bus.scheduler import LoopScheduler
from gateway.protocol.command_text import parse
from gateway.sim.cli import build_loop
from gateway.sim.clock import SimClock
from gateway.sim.faults import FaultKind, FaultRule, Faults
from gateway.sim.loop import SimLoop
from gateway.sim.serve import PtyLine
from gateway.transport.serial_line import SerialLine
from tests.support.bus_rig import HOST_LATENCY, SCALE, MakeBus

BODIES = "123"
MOTORS = (1, 2)
NOISE = ((FaultKind.NAK, 0.05), (FaultKind.DROP, 0.02), (FaultKind.GARBLE, 0.01))
#: Counters start here, and absolute targets lie around it: far from 0, where EP0 positions
#: wrap to 16,777,215 (§7-4), and well inside the default scene's stroke (no limit stops).
START = 20_000


def noisy(seed: int) -> Faults:
    faults = Faults(seed=seed)
    for kind, p in NOISE:
        faults.add(FaultRule(kind, probability=p))
    return faults


@dataclass
class Ledger:
    """Where each motor may be, after the moves as the scheduler reported them."""

    possible: dict[tuple[str, int], set[int]] = field(
        default_factory=lambda: {k: {START} for k in itertools.product(BODIES, MOTORS)}
    )
    commands: int = 0
    outcomes: dict[Outcome, int] = field(default_factory=lambda: dict.fromkeys(Outcome, 0))

    def moved(self, key: tuple[str, int], outcome: Outcome, to: Callable[[int], int]) -> None:
        self.outcomes[outcome] += 1
        if outcome is Outcome.DONE:
            self.possible[key] = {to(x) for x in self.possible[key]}
        elif outcome is Outcome.UNKNOWN:
            self.possible[key] |= {to(x) for x in self.possible[key]}


Submit = Callable[..., Awaitable[object]]


async def wait_idle(scheduler: LoopScheduler, body: str, ledger: Ledger) -> None:
    for _ in range(5000):
        ledger.commands += 1
        result = await scheduler.submit(body, parse(""), priority=Priority.OPERATOR)
        status = result.value  # type: ignore[attr-defined]
        if status is not None and not status.moving:
            return
    raise AssertionError(f"body {body} still moving")


async def mover(scheduler: LoopScheduler, body: str, moves: int, rng: random.Random,
                ledger: Ledger) -> None:  # fmt: skip
    """Absolute (§10 3) and incremental (§10 4, 5) moves, one at a time per controller."""
    for n in range(moves):
        motor = MOTORS[n % 2]
        kind = rng.choice("345")
        value = START + rng.randrange(-3000, 3000) if kind == "3" else rng.randrange(50, 400)
        # '2' (shared position data) and the move in one transaction: nobody interleaves.
        result = await scheduler.submit(body, [parse(f"2{value}"), parse(f"{kind}{motor}")])
        ledger.commands += 2
        move = result.results[1]  # type: ignore[attr-defined]
        if kind == "3":
            ledger.moved((body, motor), move.outcome, lambda _x, v=value: v)
        else:
            sign = 1 if kind == "4" else -1
            ledger.moved((body, motor), move.outcome, lambda x, d=sign * value: x + d)
        await wait_idle(scheduler, body, ledger)


async def chatter(scheduler: LoopScheduler, body: str, count: int, rng: random.Random,
                  ledger: Ledger) -> None:  # fmt: skip
    """Queries and settings from other callers, meanwhile."""
    for _ in range(count):
        motor = rng.choice(MOTORS)
        text = rng.choice((f"6{motor}", "OH", "OL", f"OH{rng.randrange(3000, 6000)}", "94"))
        per_motor = text.startswith("O")
        priority = rng.choice((Priority.POLL, Priority.OPERATOR))
        result = await scheduler.submit(
            body, parse(text), motor=motor if per_motor else None, priority=priority
        )
        assert result.results, "every caller gets an answer"  # type: ignore[attr-defined]
        ledger.commands += 1


async def campaign(scheduler: LoopScheduler, sim: SimLoop, moves: int, chat: int) -> Ledger:
    """Run the campaign; check the final positions; the ledger."""
    rng = random.Random(11)
    ledger = Ledger()
    for body in BODIES:  # a known start (§10 R)
        for motor in MOTORS:
            await scheduler.submit(body, parse(f"R{START}"), motor=motor)
    chatters = [chatter(scheduler, b, chat, rng, ledger) for b in BODIES * 2]
    movers = [mover(scheduler, b, moves, rng, ledger) for b in BODIES]
    await asyncio.gather(*movers, *chatters)
    for (body, motor), possible in ledger.possible.items():
        snapshot = sim.unit(body).device.snapshot(sim.now())
        position = int(snapshot["axes"][str(motor)]["position"])
        assert position in possible, (body, motor, position, sorted(possible)[:10])
    counters = scheduler.snapshot()
    assert counters.naks > 0 and counters.timeouts > 0 and counters.verifications > 0
    assert ledger.outcomes[Outcome.DONE] >= 0.9 * moves * len(BODIES)
    return ledger


async def test_two_thousand_commands_on_a_noisy_line_never_move_a_motor_twice(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus(BODIES, faults=noisy(7))
    # 600 move commands and 6 x 235 chats: 2,010 whatever the machine's speed (the status reads
    # that wait for each move's end come on top, fewer when the host is slow).
    ledger = await campaign(bus.scheduler, bus.sim, moves=100, chat=235)
    assert ledger.commands >= 2000


@pytest.fixture
async def pty_bus() -> AsyncIterator[tuple[LoopScheduler, SimLoop]]:
    sim = build_loop(list(BODIES), clock=SimClock(SCALE), faults=noisy(5))
    pty = PtyLine(sim)
    line = SerialLine(pty.start(), 9600)
    scheduler = LoopScheduler(line, LoopConfig(time_scale=SCALE, host_latency=HOST_LATENCY))
    await scheduler.start()
    yield scheduler, sim
    await scheduler.close()
    pty.close()
    sim.close()


async def test_the_campaign_over_a_real_pseudo_terminal(
    pty_bus: tuple[LoopScheduler, SimLoop],
) -> None:
    scheduler, sim = pty_bus
    ledger = await campaign(scheduler, sim, moves=20, chat=30)
    assert ledger.commands >= 300
