"""A loop served by a line worker: what service/ gets through the proxy is what it gets from
the scheduler in its own process (replies, errors, the state), and a stop is never held
behind a request on the channel.

The worker and its client run on the test's event loop, joined by socketpairs: every request,
reply, change and event crosses as bytes, as between processes. The simulator's line log says
what reached the wire.
"""

from __future__ import annotations

import asyncio
import dataclasses

import pytest

from gateway.bus.events import BusEvent, LinkDown
from gateway.bus.lifecycle import LinkState
from gateway.bus.requests import LoopDown, Outcome, TransactionError
from gateway.bus.state_types import AxisState, Change, ControllerState
from gateway.engine.wire import Kind, encode
from gateway.protocol.command_text import parse
from gateway.protocol.program import parse_program
from tests.support.engine_rig import Attach, MakeBus
from tests.support.state_waits import until_state


def _without_time(record: AxisState | ControllerState) -> AxisState | ControllerState:
    """A record without the time of its latest reply (the mirror learns it with a change)."""
    return dataclasses.replace(record, updated=None)


async def test_a_request_through_the_worker_reaches_the_wire_and_its_reply_comes_back(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.proxy
    assert proxy.state is LinkState.UP
    result = await proxy.submit("1", [parse("A0051234"), parse("A005D")])
    assert result.outcome is Outcome.DONE
    assert result.value == 1234  # decoded in the worker, carried back as the bus's own result
    assert bus.texts()[-2:] == ["A0051234", "A005D"]


async def test_the_mirror_follows_the_worker_state_change_by_change(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.proxy
    mirror, cache = linked.mirror, linked.cache
    await proxy.submit("1", parse("7"), motor=1)  # jog motor 1: the cache learns it moves
    await until_state(mirror, lambda: mirror.axis(proxy.name, "1", 1).moving is True, 5.0)
    await proxy.stop("1", parse("S"))
    await bus.wait_idle("1")
    await until_state(
        mirror, lambda: mirror.source_seq("w0") == cache.seq, 5.0
    )  # every change of the worker's cache applied, in order
    assert mirror.axis(proxy.name, "1", 1).moving is False
    assert _without_time(mirror.controller(proxy.name, "1")) == _without_time(
        cache.controller(proxy.name, "1")
    )
    for motor in (1, 2):
        assert _without_time(mirror.axis(proxy.name, "1", motor)) == _without_time(
            cache.axis(proxy.name, "1", motor)
        )


async def test_the_bus_errors_cross_with_their_class_and_fields(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.proxy
    with pytest.raises(TransactionError) as far:
        await proxy.submit("F", parse(""))  # F is the inspection mode, not a body (§3-III)
    with pytest.raises(TransactionError) as near:
        await bus.scheduler.submit("F", parse(""))
    assert str(far.value) == str(near.value)
    bus.unplug()
    with pytest.raises(LoopDown) as down:
        await asyncio.wait_for(proxy.submit("1", parse("")), 5.0)
    assert down.value.loop == proxy.name and down.value.cause
    assert proxy.state is not LinkState.UP and proxy.cause == bus.scheduler.cause


async def test_a_stop_overtakes_a_request_stuck_on_the_request_channel(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.proxy
    await proxy.submit("1", parse("7"), motor=1)
    # A request whose bytes are only half in: the worker's request reader waits for the rest.
    frame = encode((Kind.SUBMIT, 999, proxy.name, "1", (parse(""),), None, None, None))
    writers = linked.client._writers
    assert writers is not None
    writers[0].write(frame[: len(frame) // 2])
    result = await asyncio.wait_for(proxy.stop("1", parse("S")), 5.0)
    assert result.outcome is Outcome.DONE
    assert bus.texts()[-1] == "S"


async def test_a_worker_gone_fails_its_requests_and_a_new_attachment_resyncs_the_mirror(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.proxy
    await linked.disconnect("line worker w0 was killed")
    assert proxy.state is LinkState.DOWN and proxy.cause == "line worker w0 was killed"
    with pytest.raises(LoopDown, match="killed"):
        await proxy.submit("1", parse(""))
    # Meanwhile the worker's loop goes on: a change the client never saw ...
    await bus.scheduler.submit("1", parse("7"), motor=1)
    assert bus.scheduler.state_cache.axis(proxy.name, "1", 1).moving is True
    assert linked.mirror.axis(proxy.name, "1", 1).moving is not True
    # ... is in the snapshot a new attachment starts with.
    await linked.connect()
    assert proxy.state is LinkState.UP
    assert linked.mirror.axis(proxy.name, "1", 1).moving is True
    await proxy.stop("1")


async def test_the_loop_counters_cross_with_each_transaction(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.proxy
    before = proxy.snapshot().transactions
    await proxy.submit("1", parse("A005D"))
    await proxy.submit("1", parse("A006D"))
    # the reply to the caller comes after the transaction's event, on the same channel
    assert proxy.snapshot().transactions == before + 2
    assert proxy.snapshot() == bus.scheduler.snapshot()
    assert proxy.queue_depth == 0


async def test_a_program_upload_goes_through_the_worker(make_bus: MakeBus, attach: Attach) -> None:
    bus = await make_bus("1", upload_chunk=16)
    linked = await attach(bus)
    proxy = linked.proxy
    program = parse_program("//22000//3//T10//4//?//T10//5//?//END")
    result = await proxy.upload_program("1", program)
    assert result.outcome is Outcome.DONE
    assert bus.controller("1").rt.program  # the simulated controller holds it


async def test_the_poller_is_started_and_stopped_through_the_worker(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.proxy
    mirror = linked.mirror
    assert mirror.controller(proxy.name, "1").online is None  # nobody polled it yet
    await proxy.polling(True)
    await until_state(mirror, lambda: mirror.controller(proxy.name, "1").online is True, 5.0)
    await proxy.polling(False)
    assert linked.worker.pollers[proxy.name]._task is None  # stopped, nothing in flight


async def test_a_reopen_at_another_rate_comes_back_as_the_link_events(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.proxy
    downs: list[LinkDown] = []
    seen = asyncio.Event()

    def note(event: BusEvent) -> None:
        if isinstance(event, LinkDown):
            downs.append(event)
            seen.set()

    proxy.events.subscribe(note)
    proxy.reopen_at(4800)
    await asyncio.wait_for(seen.wait(), 5.0)
    assert "4800" in downs[0].cause
    assert bus.scheduler.timing.baud == 4800


async def test_the_supervisors_word_on_a_death_is_the_last_whatever_the_readers_do(
    make_bus: MakeBus, attach: Attach
) -> None:
    # The channel's reader lets go first ("went away"), the supervisor says how the worker
    # ended while that reader is still cancelling the other: requests must get the latter.
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.proxy
    reader = asyncio.create_task(linked.client.detach("line worker w0 went away"))
    supervisor = asyncio.create_task(
        linked.client.detach("line worker w0 was killed by SIGKILL", retry_after=3.0)
    )
    await asyncio.gather(reader, supervisor)
    assert proxy.cause == "line worker w0 was killed by SIGKILL" and proxy.retry_after == 3.0
    with pytest.raises(LoopDown) as refused:
        await proxy.submit("1", parse(""))
    assert refused.value.retry_after == 3.0
    if linked.served is not None:
        await asyncio.wait_for(linked.served, 5.0)


async def test_the_proxy_says_what_the_mirror_says_of_the_link_as_soon_as_it_says_it(
    make_bus: MakeBus, attach: Attach
) -> None:
    # The worker's cache hears the scheduler's link events first, so its change reaches the
    # API process before the link event itself: a WebSocket client told by that change that
    # the loop is down (or up) and asking REST at once must hear the same from the proxy.
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.proxy
    mirror = linked.mirror
    seen: list[tuple[bool, LinkState]] = []
    back = asyncio.Event()

    def note(change: Change) -> None:
        if change.body is None and "up" in change.values:
            seen.append((bool(change.values["up"]), proxy.state))
            if change.values["up"]:
                back.set()

    mirror.changes.subscribe(note)
    proxy.reopen_at(4800)
    await asyncio.wait_for(back.wait(), 5.0)
    assert seen[0] == (False, LinkState.DOWN), seen
    assert seen[-1] == (True, LinkState.UP), seen
