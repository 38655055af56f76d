"""A stop is the very next frame on the wire, even in the middle of a transaction.

What is checked is the simulator's line log: the frames it heard, in order. The moment a stop
is asked for, the scheduler's own trace says how many frames it had written; the stop must be
the next one heard. A stop to the controller of the transaction it overtook also ends what
that transaction had still to do that acts: the move queued behind the stop never goes out.
"""

from __future__ import annotations

import asyncio

from gateway.bus.events import BusEvent, ReplyObserved
from gateway.bus.requests import Outcome, Priority, ReplyKind, TransactionResult
from gateway.bus.trace import FrameDirection
from gateway.protocol.command_text import parse
from tests.support.bus_rig import Bus, MakeBus

#: Eight reads of program lines (§10 A: a query, shared by both motors).
READS = [f"A{n:03d}D" for n in range(8)]


def _written(bus: Bus) -> int:
    """Frames the scheduler has written so far (its trace is on for the whole loop)."""
    return sum(1 for r in bus.scheduler.trace.records() if r.direction is FrameDirection.TX)


def _stop_after(
    bus: Bus, wire: str, body: str, command: str
) -> tuple[list[int], list[asyncio.Future[TransactionResult]]]:
    """Ask for a stop once a reply to ``wire`` has been published; how many frames were
    written then, and the stop's result."""
    written: list[int] = []
    stops: list[asyncio.Future[TransactionResult]] = []

    def watch(event: BusEvent) -> None:
        if isinstance(event, ReplyObserved) and event.command.wire() == wire and not stops:
            written.append(_written(bus))
            stops.append(asyncio.ensure_future(bus.scheduler.stop(body, parse(command))))

    bus.scheduler.events.subscribe(watch)
    return written, stops


async def test_a_stop_to_another_controller_goes_between_two_frames_of_a_transaction(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("12")
    bus.scheduler.trace.enable()
    written, stops = _stop_after(bus, "A001D", "2", "SS")
    result = await bus.scheduler.submit("1", [parse(t) for t in READS])
    stop = await asyncio.wait_for(stops[0], 5.0)
    heard = [f.decode("latin-1") for f in bus.frames()]
    n = written[0]
    assert 2 <= n < len(READS)  # asked for while the transaction was on the line
    # The stop is the next frame after those written when it was asked for ...
    assert heard[n] == "$2SS\r", heard
    # ... and the transaction to the other controller goes on after it, whole and in order.
    assert [h for h in heard if h.startswith("$1")] == [f"$1{t}\r" for t in READS]
    assert result.ok and stop.outcome is Outcome.DONE


async def test_a_stop_to_the_same_controller_cancels_the_move_queued_behind_it(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1")
    bus.scheduler.trace.enable()
    written, stops = _stop_after(bus, "A001D", "1", "S")
    # Reads, then a move of motor 1 (§10 2: target, §10 3: go) in one transaction.
    commands = [parse(t) for t in [*READS[:4], "21000", "31"]]
    result = await bus.scheduler.submit("1", commands, motor=1, priority=Priority.OPERATOR)
    await asyncio.wait_for(stops[0], 5.0)
    texts = bus.texts("1")
    n = written[0]
    assert texts[n] == "S", texts
    # The reads still asked for are made; nothing that acts goes out after the stop.
    assert "21000" not in texts and "31" not in texts, texts
    assert texts[n + 1 :] == READS[n:4], texts
    assert bus.position() == 0  # the motor never moved
    target = next(r for r in result.results if r.command.wire() == "21000")
    assert target.kind is ReplyKind.SKIPPED and target.outcome is Outcome.NOT_DONE
    assert "stop" in target.note
    assert not result.ok


async def test_a_stop_queued_between_transactions_goes_before_the_queue(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("12")
    bus.scheduler.trace.enable()
    written, stops = _stop_after(bus, "A000D", "2", "S")
    polls = [
        asyncio.ensure_future(bus.scheduler.submit("1", parse(t), priority=Priority.POLL))
        for t in READS
    ]
    await asyncio.gather(*polls)
    await asyncio.wait_for(stops[0], 5.0)
    heard = [f.decode("latin-1") for f in bus.frames()]
    assert heard[written[0]] == "$2S\r", heard
