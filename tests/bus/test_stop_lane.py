"""The stop lane: stops asked for while a transaction is between two frames.

Every stop queued in that gap goes out before the transaction's next frame, in the order the
stops were asked for, and each answers its caller before the transaction it overtook ends; a
stop to the transaction's own controller leaves the rest of what acts `not_done`. While an
EEPROM write holds the line, the stops go out meanwhile in their order too. What is checked is
the simulator's line log (the frames it heard, in order) and the callers' results.
"""

from __future__ import annotations

import asyncio

from gateway.bus.events import BusEvent, ReplyObserved
from gateway.bus.requests import Outcome, ReplyKind, TransactionResult
from gateway.bus.trace import FrameDirection
from gateway.protocol.command_text import parse
from gateway.sim.clock import RecordKind
from tests.support.bus_rig import Bus, MakeBus

#: Reads of program lines (§10 A: a query, shared by both motors), then a move of motor 1
#: (§10 2: target, §10 3: go).
READS = [f"A{n:03d}D" for n in range(6)]
MOVE = ["21000", "31"]


def _written(bus: Bus) -> int:
    """Frames the scheduler has written so far (its trace is on for the whole loop)."""
    return sum(1 for r in bus.scheduler.trace.records() if r.direction is FrameDirection.TX)


async def test_stops_asked_for_in_one_gap_all_go_before_the_next_frame_in_their_order(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("12")
    bus.scheduler.trace.enable()
    written: list[int] = []
    stops: list[asyncio.Future[TransactionResult]] = []

    def two_stops(event: BusEvent) -> None:
        if isinstance(event, ReplyObserved) and event.command.wire() == "A001D" and not stops:
            written.append(_written(bus))
            stops.append(asyncio.ensure_future(bus.scheduler.stop("2", parse("SS"))))
            stops.append(asyncio.ensure_future(bus.scheduler.stop("1", parse("S"))))

    bus.scheduler.events.subscribe(two_stops)
    commands = [parse(t) for t in [*READS, *MOVE]]
    result = await bus.scheduler.submit("1", commands, motor=1)
    other, own = await asyncio.wait_for(asyncio.gather(*stops), 5.0)

    heard = [f.decode("latin-1") for f in bus.frames()]
    n = written[0]
    assert 2 <= n < len(READS), heard  # asked for while the transaction was on the line
    # Both stops are the next frames, in the order they were asked for ...
    assert heard[n : n + 2] == ["$2SS\r", "$1S\r"], heard
    # ... then the transaction goes on with its reads only: the move never goes out.
    assert [h for h in heard[n + 2 :]] == [f"$1{t}\r" for t in READS[n:]], heard
    assert bus.position() == 0
    target = next(r for r in result.results if r.command.wire() == MOVE[0])
    assert target.kind is ReplyKind.SKIPPED and target.outcome is Outcome.NOT_DONE
    assert "stop" in target.note
    # Each stop's caller has its answer before the transaction it overtook has ended.
    assert other.outcome is Outcome.DONE and own.outcome is Outcome.DONE
    assert other.ended <= own.started and own.ended <= result.ended
    assert result.started < other.started


async def test_stops_asked_for_during_an_eeprom_hold_go_in_their_order(make_bus: MakeBus) -> None:
    bus = await make_bus("123")
    stops: list[asyncio.Future[TransactionResult]] = []

    def two_stops() -> None:
        stops.append(asyncio.ensure_future(bus.scheduler.stop("2", parse("SS"))))
        stops.append(asyncio.ensure_future(bus.scheduler.stop("3", parse("S"))))

    bus.once_after("EE///", two_stops)
    erase = await bus.scheduler.submit("1", parse("EE///"))
    other, third = await asyncio.wait_for(asyncio.gather(*stops), 5.0)
    assert erase.outcome is Outcome.DONE
    assert other.outcome is Outcome.DONE and third.outcome is Outcome.DONE
    sequence = [
        r.data for r in bus.records() if r.kind in (RecordKind.HEARD, RecordKind.LATER) and r.data
    ]
    # §10 EE///: the line is held until '$1*' (10-20 s); the stops go out meanwhile, in the
    # order they were asked for.
    assert sequence == [b"$1EE///\r", b"$2SS\r", b"$3S\r", b"$1*\r"], sequence
