"""The framing of each controller has one home (§10 EE, EL, ER, SUM): the state cache.

The scheduler decides it (set through the gateway, read back, forgotten after a doubt) and
reads it back from the state cache; clients read the same record. So what the line sends and
what the gateway publishes cannot disagree: after ``SUM1`` both carry checksums; after a
reconnect or a controller's power cycle both say the framing is not known (the line assumes
the loop's initial one), until it is read back or set again.

Checksummed frames are the manual's own vectors (§10 SUM: '$16' CR is sent as '$168B' CR).
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Awaitable, Callable

import pytest

from gateway.bus.events import BusEvent, FramingChanged, LinkUp
from gateway.bus.requests import Outcome
from gateway.bus.state import StateCache
from gateway.protocol.command_text import parse
from gateway.protocol.framing import POWER_ON, Framing
from tests.support.bus_rig import Bus, MakeBus
from tests.support.poll_rig import LOOP, MakeRig, Rig, poller_rigs

EL_SUM = Framing(cr_after_ack=True, checksum=True)
SUM = Framing(checksum=True)


def published(bus: Bus, body: str = "1") -> Framing | None:
    """The framing the state cache shows for ``body`` (what every face reads)."""
    return bus.scheduler.state_cache.controller(bus.scheduler.name, body).framing


def watch_agreement(bus: Bus, body: str = "1") -> list[tuple[Framing, Framing | None]]:
    """After every event of the scheduler: the framing it sends with beside the one the cache
    publishes, whenever they differ (the list stays empty while they agree)."""
    disagreements: list[tuple[Framing, Framing | None]] = []

    def check(event: BusEvent) -> None:
        shown = published(bus, body)
        used = bus.scheduler.framing(body)
        if used != (shown or bus.scheduler.config.initial_framing):
            disagreements.append((used, shown))

    bus.scheduler.events.subscribe(check)
    return disagreements


async def set_el_sum(bus: Bus) -> None:
    """EL1 and SUM1 through the gateway; '$16' then goes out with its checksum (§10 SUM)."""
    for text in ("EL1", "SUM1"):
        assert (await bus.scheduler.submit("1", parse(text))).outcome is Outcome.DONE
    assert await bus.query("1", "6") == 0
    assert bus.frames()[-1] == b"$168B\r"


async def test_after_sum1_the_line_and_the_published_framing_agree(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    disagreements = watch_agreement(bus)
    await set_el_sum(bus)
    assert published(bus) == bus.scheduler.framing("1") == EL_SUM
    assert bus.controller().framing == EL_SUM  # and so does the controller
    # A refused switch (EE1 under SUM1, §10 EE) changes neither.
    await bus.scheduler.submit("1", parse("EE1"))
    assert published(bus) == bus.scheduler.framing("1") == EL_SUM
    assert disagreements == []


async def test_a_reconnect_forgets_both_until_read_back(make_bus: MakeBus) -> None:
    bus = await make_bus("1", reconnect_initial_real=0.01, reconnect_max_real=0.04)
    disagreements = watch_agreement(bus)
    await set_el_sum(bus)
    up = asyncio.Event()
    bus.scheduler.events.subscribe(lambda e: up.set() if isinstance(e, LinkUp) else None)
    bus.unplug()
    bus.plug()
    await asyncio.wait_for(up.wait(), 10.0)
    # Nobody knows what the controllers did meanwhile: not known, the initial one assumed.
    assert published(bus) is None
    assert bus.scheduler.framing("1") == POWER_ON
    # The controller kept SUM1: '$16' without a checksum is refused ('?', §10 SUM) until the
    # framing is read back; then both show it again.
    mark = len(bus.frames())
    assert await bus.query("1", "6") == 0
    # '$16' refused each time, SUM asked without then with a checksum, the others with one.
    assert bus.frames()[mark:] == [b"$16\r"] * 4 + [
        b"$1SUM\r",
        b"$1SUM4A\r",
        b"$1EEDF\r",
        b"$1ELE6\r",
        b"$1EREC\r",
        b"$168B\r",
    ]
    assert published(bus) == bus.scheduler.framing("1") == EL_SUM
    changes = [(e.framing, e.detected) for e in bus.events if isinstance(e, FramingChanged)]
    assert changes[-2:] == [(None, False), (EL_SUM, True)]
    assert disagreements == []


async def test_a_power_cycle_forgets_both(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    disagreements = watch_agreement(bus)
    await set_el_sum(bus)
    # Switched off and on: the RAM framing is lost, the factory one is back (§16; no DW).
    unit = bus.sim.unit("1")
    bus.sim.act(lambda now: bus.sim.power_cycle(unit, now))
    bus.scheduler.forget("1")  # what the poller does when a controller answers again
    assert published(bus) is None
    assert bus.scheduler.framing("1") == POWER_ON
    assert await bus.query("1", "6") == 0
    assert bus.frames()[-1] == b"$16\r"  # no checksum: the line's framing is the assumed one
    assert bus.controller().framing == POWER_ON
    assert published(bus) is None  # still not known: nothing read it back or set it
    assert disagreements == []


async def test_a_shared_cache_holds_the_framing_the_line_uses(make_bus: MakeBus) -> None:
    # The scheduler of a running gateway feeds and reads the one state cache (``use_state``);
    # what it decides is there, not in a copy of its own.
    bus = await make_bus("1")
    shared = StateCache()
    bus.scheduler.use_state(shared, first=False)
    await set_el_sum(bus)
    assert shared.controller(bus.scheduler.name, "1").framing == EL_SUM
    # Forgotten there (as a reconnect does), the line assumes the initial framing again.
    bus.scheduler.forget("1")
    assert shared.controller(bus.scheduler.name, "1").framing is None
    assert bus.scheduler.framing("1") == POWER_ON


@pytest.fixture
async def rig() -> AsyncIterator[MakeRig]:
    async with poller_rigs(2.0) as make:
        yield make


async def test_a_controller_switched_off_and_on_is_unknown_in_both(
    rig: Callable[..., Awaitable[Rig]],
) -> None:
    # The poller's path: silent, then answering again (its RAM, the framing among it, lost,
    # §16): the scheduler forgets the framing, and the published one is not known either.
    r = await rig("12", idle_period=0.2, probe_initial=0.4, probe_max=2.0)
    await r.identified("12")
    for body in "12":
        assert (await r.scheduler.submit(body, parse("SUM1"))).outcome is Outcome.DONE
        assert r.state.controller(LOOP, body).framing == SUM
    r.controls.power("2", False)
    await r.until(lambda: r.state.controller(LOOP, "2").online is False)
    on = r.sim.now()
    r.controls.power("2", True)
    # Identified again, without a checksum: the poller found it back and the scheduler forgot.
    await r.until(lambda: bool(r.frames(b"$2V\r", since=on)))
    assert r.state.controller(LOOP, "2").framing is None
    assert r.scheduler.framing("2") == POWER_ON
    # The other controller kept its own, on the line and in the state.
    assert r.state.controller(LOOP, "1").framing == r.scheduler.framing("1") == SUM
