"""Link health: the port goes away and comes back; the line goes silent (half-open)."""

from __future__ import annotations

import asyncio

import pytest

from gateway.bus.events import BusEvent, LinkDown, LinkUp
from gateway.bus.requests import LoopDown, Outcome
from gateway.bus.scheduler import LinkState
from gateway.protocol.command_text import parse
from tests.support.bus_rig import Bus, MakeBus


def waiter(bus: Bus, kind: type[BusEvent]) -> asyncio.Event:
    """An event set at the next ``kind`` published."""
    seen = asyncio.Event()
    bus.scheduler.events.subscribe(lambda e: seen.set() if isinstance(e, kind) else None)
    return seen


async def test_the_loop_goes_down_fails_fast_and_comes_back(make_bus: MakeBus) -> None:
    bus = await make_bus("1", reconnect_initial_real=0.01, reconnect_max_real=0.04)
    await bus.scheduler.submit("1", parse("OH4000"), motor=2)
    down, up = waiter(bus, LinkDown), waiter(bus, LinkUp)
    bus.unplug()
    await asyncio.wait_for(down.wait(), 5.0)
    assert bus.scheduler.state is LinkState.DOWN
    loop = asyncio.get_running_loop()
    started = loop.time()
    with pytest.raises(LoopDown) as caught:
        await bus.scheduler.submit("1", parse("OL400"), motor=2)
    assert loop.time() - started < 0.01  # at once, not after a time-out
    error = caught.value
    assert "loop 'loop' is down" in str(error)
    assert "closed" in error.cause or "unplugged" in error.cause
    assert error.retry_after is not None and not error.in_flight
    before = len(bus.texts())
    bus.plug()
    await asyncio.wait_for(up.wait(), 5.0)
    # Up only once the controller answered: the probe (97) read the selection back from the
    # device, so motor 2 needs no F2 (the cache of the time before the outage was dropped).
    assert bus.texts()[before:] == ["97"]
    assert bus.scheduler.selected_motor("1") == 2
    mark = len(bus.texts())
    assert (await bus.scheduler.submit("1", parse("OL400"), motor=2)).outcome is Outcome.DONE
    assert bus.texts()[mark:] == ["OL400"]
    kinds = [type(e) for e in bus.events if isinstance(e, (LinkDown, LinkUp))]
    assert kinds == [LinkUp, LinkDown, LinkUp]  # connected, unplugged, plugged again
    assert bus.scheduler.snapshot().link_downs >= 1


async def test_a_transaction_in_flight_when_the_port_goes_says_so(make_bus: MakeBus) -> None:
    bus = await make_bus("1", reconnect_initial_real=0.01)
    bus.once_after("EE///", bus.unplug)
    queued = asyncio.ensure_future(bus.scheduler.submit("1", parse("OH")))
    with pytest.raises(LoopDown) as caught:
        await bus.scheduler.submit("1", parse("EE///"))
    assert caught.value.in_flight
    assert "may have acted" in str(caught.value)
    with pytest.raises(LoopDown):
        await queued  # queued requests fail at once too


async def test_time_outs_in_a_row_with_silence_take_the_loop_down(make_bus: MakeBus) -> None:
    bus = await make_bus("1", timeouts_to_down=4, reconnect_initial_real=0.01)
    down, up = waiter(bus, LinkDown), waiter(bus, LinkUp)
    bus.sim.act(lambda now: bus.sim.set_cut(True, now))
    with pytest.raises(LoopDown) as caught:
        for _ in range(10):
            await bus.scheduler.submit("1", parse("A000D"))
    assert "4 time-outs in a row" in caught.value.cause
    await asyncio.wait_for(down.wait(), 5.0)
    bus.sim.act(lambda now: bus.sim.set_cut(False, now))
    await asyncio.wait_for(up.wait(), 5.0)
    assert (await bus.query("1", "A000D")) == 0


async def test_closing_fails_the_transaction_in_flight_and_the_queue(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    closing: list[asyncio.Task[None]] = []
    bus.once_after("EE///", lambda: closing.append(asyncio.ensure_future(bus.scheduler.close())))
    queued = asyncio.ensure_future(bus.scheduler.submit("1", parse("OH")))
    with pytest.raises(LoopDown) as caught:
        await bus.scheduler.submit("1", parse("EE///"))
    assert caught.value.in_flight
    with pytest.raises(LoopDown, match="closed"):
        await queued
    await asyncio.gather(*closing)
    assert bus.scheduler.state is LinkState.CLOSED
    with pytest.raises(LoopDown, match="closed"):
        await bus.scheduler.submit("1", parse("OH"))
