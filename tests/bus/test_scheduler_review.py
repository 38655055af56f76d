"""Findings of the review of the loop scheduler (brief R1): each test failed before its fix.

* a stop whose caller went away, or that was given a deadline, still reaches the wire
  (DESIGN invariant 8: a stop is never dropped and never expires);
* a transport whose ``open`` fails with an error the scheduler did not expect does not kill
  the scheduler's task: callers get ``LoopDown`` instead of waiting forever;
* a per-motor command never goes out after the selection was put in doubt by the scheduler's
  own pre-read (DESIGN invariant 5): a controller power-cycled meanwhile selects motor 1.
"""

from __future__ import annotations

import asyncio

import pytest

from gateway.bus.config import LoopConfig
from gateway.bus.events import ReplyObserved
from gateway.bus.requests import LoopDown, Outcome, Priority, TransactionError
from gateway.bus.scheduler import LoopScheduler
from gateway.protocol import commands as cmd
from gateway.protocol.command_text import parse
from gateway.sim.faults import FaultKind
from gateway.transport.base import Transport, TransportClosed
from tests.support.bus_rig import MakeBus


def _block() -> list[object]:
    return [parse(f"A{n:03d}D") for n in range(8)]


async def test_a_stop_whose_caller_went_away_still_goes_out(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    stop: list[asyncio.Task[object]] = []

    def queue_then_cancel(event: object) -> None:
        # Queue the stop during the first frame of the block, abandon it during the second.
        if not isinstance(event, ReplyObserved) or event.command.key != "A{pn}D":
            return
        if not stop:
            stop.append(asyncio.ensure_future(bus.scheduler.stop("1", cmd.slow_stop())))
        elif not stop[0].done():
            stop[0].cancel()

    bus.scheduler.events.subscribe(queue_then_cancel)
    await bus.scheduler.submit("1", _block())  # type: ignore[arg-type]
    await bus.scheduler.submit("1", parse(""))
    assert stop and stop[0].cancelled()
    # The machine must stop although the HTTP client that asked went away.
    # (It goes out before the block's next frame: the block's reads go on after it.)
    texts = bus.texts()
    assert texts.count("SS") == 1 and texts[-1] == "", texts
    assert [t for t in texts if t != "SS"] == [c.wire() for c in _block()] + [""]  # type: ignore[attr-defined]


async def test_a_stop_never_expires_by_deadline(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    stop: list[asyncio.Future[object]] = []

    def stop_now(event: object) -> None:
        if isinstance(event, ReplyObserved) and not stop:
            # A deadline far shorter than the transaction in flight.
            stop.append(
                asyncio.ensure_future(bus.scheduler.submit("1", parse("S"), deadline=0.0001))
            )

    bus.scheduler.events.subscribe(stop_now)
    await bus.scheduler.submit("1", _block())  # type: ignore[arg-type]
    result = await asyncio.wait_for(stop[0], 5.0)
    assert result.outcome is Outcome.DONE  # type: ignore[attr-defined]
    texts = bus.texts()
    assert texts.count("S") == 1 and texts.index("S") < 8, texts  # before the block's end


class _BrokenDriver(Transport):
    """A line whose driver fails to open with an error nobody planned for."""

    url = "broken://"
    baud = 9600

    def __init__(self) -> None:
        self.opens = 0

    async def open(self) -> None:
        self.opens += 1
        raise RuntimeError("driver bug")

    async def close(self) -> None:
        return None

    @property
    def is_open(self) -> bool:
        return False

    def write(self, data: bytes) -> None:
        raise TransportClosed("not open")

    async def read(self) -> bytes:
        raise TransportClosed("not open")

    def discard_input(self) -> bytes:
        return b""


async def test_an_unexpected_open_error_does_not_kill_the_scheduler() -> None:
    transport = _BrokenDriver()
    config = LoopConfig(reconnect_initial_real=0.01, reconnect_max_real=0.01)
    scheduler = LoopScheduler(transport, config)
    try:
        await scheduler.start()
        # The caller learns the loop is down at once; it does not wait forever.
        with pytest.raises(LoopDown, match="driver bug"):
            await asyncio.wait_for(scheduler.stop("1"), 2.0)
        # And the scheduler keeps trying to reopen the line.
        for _ in range(200):
            if transport.opens >= 3:
                break
            await asyncio.wait_for(asyncio.shield(asyncio.sleep(0.01)), 1.0)
        assert transport.opens >= 3
    finally:
        await scheduler.close()


async def test_a_pre_read_in_doubt_selects_the_motor_again(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    oh2 = await bus.query("1", "OH", motor=2)
    oh1 = await bus.query("1", "OH", motor=1)  # motor 1 selected: OHI for motor 2 needs F2

    def power_cycle_and_lose_replies() -> None:
        # Right after F2 was confirmed: the controller restarts (motor 1 selected, §16) and
        # the replies to the read of OH before OHI (1 + resend_retries sends) are lost.
        unit = bus.sim.unit("1")
        bus.sim.act(lambda now: bus.sim.power_cycle(unit, now))
        bus.fault(FaultKind.DROP, shots=3)

    bus.once_after("97", power_cycle_and_lose_replies)
    result = await bus.scheduler.submit("1", parse("OHI100"), motor=2)
    assert result.outcome is Outcome.DONE
    texts = bus.texts()
    last = texts.index("OHI100")
    assert texts[last - 2 : last] == ["F2", "97"]  # selected again after the doubt
    assert await bus.query("1", "OH", motor=1) == oh1  # motor 1 untouched
    assert await bus.query("1", "OH", motor=2) == oh2 + 100


async def test_stop_priority_is_for_stops_only(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    with pytest.raises(TransactionError, match="priority STOP is for stops only"):
        await bus.scheduler.submit("1", parse("OH4000"), priority=Priority.STOP)
    assert "OH4000" not in bus.texts()  # nothing of it reached the wire
