"""The scheduler's core on the simulator: one frame in flight, priorities, retries, late replies.

Every assertion is about what a user of the line would notice: the frames the simulated
controllers heard (the simulator's line log), the values and outcomes the callers got, and the
controllers' own state afterwards.
"""

from __future__ import annotations

import asyncio
import gc

import pytest

from gateway.bus.events import ReplyObserved, TransactionDone
from gateway.bus.requests import (
    DeadlineExpired,
    Outcome,
    Priority,
    ReplyKind,
    TransactionError,
)
from gateway.protocol import commands as cmd
from gateway.protocol.command_text import parse
from gateway.protocol.reply_values import StatusFlags
from gateway.sim.clock import RecordKind
from gateway.sim.faults import FaultKind
from tests.support.bus_rig import MakeBus


async def test_a_query_goes_out_as_the_manual_frames_it(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    result = await bus.scheduler.submit("1", parse(""))
    # §10 "" (I): '$1' CR -> '>$10' CR, motor stopped, no errors
    assert bus.frames() == [b"$1\r"]
    assert [r.data for r in bus.records(RecordKind.REPLY)] == [b">$10\r"]
    assert result.value == StatusFlags()
    assert result.outcome is Outcome.DONE
    counters = bus.scheduler.snapshot()
    assert (counters.bytes_out, counters.bytes_in) == (3, 5)
    # 8 characters of 10 bits at 9600 bps
    assert counters.busy_time == pytest.approx(8 * 10 / 9600)


async def test_commands_are_models_never_text(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    with pytest.raises(TransactionError):
        await bus.scheduler.submit("1", ["OH4000"])  # type: ignore[list-item]
    with pytest.raises(TransactionError):
        await bus.scheduler.submit("F", parse(""))  # F is the inspection mode (§3-III)
    assert bus.frames() == []


async def test_priorities_first_then_fifo(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    order = [
        (Priority.POLL, "OH"),
        (Priority.OPERATOR, "OL"),
        (Priority.POLL, "OS"),
        (Priority.OPERATOR, "OX"),
        (Priority.STOP, "S"),
        (Priority.POLL, "0S"),
    ]
    tasks: list[asyncio.Task[object]] = []

    def queue_all(event: object) -> None:
        # Queued while the first transaction is in flight, all at once.
        if isinstance(event, ReplyObserved) and not tasks:
            for priority, text in order:
                tasks.append(
                    asyncio.ensure_future(bus.scheduler.submit("1", parse(text), priority=priority))
                )

    bus.scheduler.events.subscribe(queue_all)
    await bus.scheduler.submit("1", [parse("A000D"), parse("A001D")])
    await asyncio.gather(*tasks)
    assert bus.texts() == ["A000D", "A001D", "S", "OL", "OX", "OH", "OS", "0S"]


async def test_a_stop_goes_out_right_after_the_transaction_in_flight(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    block = [parse(f"A{n:03d}D") for n in range(8)]
    polls = [
        asyncio.ensure_future(
            bus.scheduler.submit("1", parse(f"A{n:03d}D"), priority=Priority.POLL)
        )
        for n in range(100, 140)
    ]
    stop: list[asyncio.Future[object]] = []

    def stop_now(event: object) -> None:
        if isinstance(event, ReplyObserved) and event.command.key == "A{pn}D" and not stop:
            stop.append(asyncio.ensure_future(bus.scheduler.stop("1", cmd.slow_stop())))

    first = asyncio.ensure_future(bus.scheduler.submit("1", block, priority=Priority.OPERATOR))
    bus.scheduler.events.subscribe(stop_now)
    await asyncio.gather(first, *polls, *stop)
    texts = bus.texts()
    # The first request out was either the block or one poll; the stop follows whichever
    # transaction was in flight, before the 40 polls still queued.
    s = texts.index("SS")
    assert s <= len(block)
    assert texts[:s] in ([t.wire() for t in block], ["A100D"], [t.wire() for t in block][:s])
    records = bus.records()
    heard = [r for r in records if r.kind is RecordKind.HEARD and r.ref > 0]
    stop_record = heard[s]
    before = heard[s - 1]
    replies = [r for r in records if r.kind is RecordKind.REPLY and r.ref == before.ref]
    # On the wire: the reply of the in-flight transaction's last frame, then the stop.
    assert replies and replies[0].seq < stop_record.seq
    assert not [r for r in heard if replies[0].seq < r.seq < stop_record.seq]


async def test_not_accepted_is_sent_again(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    bus.fault(FaultKind.NAK, shots=2)
    result = await bus.scheduler.submit("1", parse("OH4000"))
    assert result.outcome is Outcome.DONE
    assert result.results[0].attempts == 3
    assert bus.texts().count("OH4000") == 3
    assert [r.data for r in bus.records(RecordKind.REPLY)][-3:] == [b"?", b"?", b">"]
    assert bus.controller().settings.motors[1].oh == 4000
    assert bus.scheduler.snapshot().naks == 2


async def test_not_accepted_every_time_is_not_done(make_bus: MakeBus) -> None:
    bus = await make_bus("1", nak_retries=2)
    await bus.scheduler.submit("1", parse("EL0"))  # the framing is known: '?' is noise
    bus.fault(FaultKind.NAK, shots=10)
    result = await bus.scheduler.submit("1", parse("OH4000"))
    assert result.outcome is Outcome.NOT_DONE
    assert result.results[0].kind is ReplyKind.NOT_ACCEPTED
    assert bus.texts().count("OH4000") == 3  # once + nak_retries
    assert bus.controller().settings.motors[1].oh == 5000  # factory value (§16)


async def test_a_dropped_reply_to_a_query_is_sent_again(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("A0051234"))
    bus.fault(FaultKind.DROP)
    result = await bus.scheduler.submit("1", parse("A005D"))
    assert result.value == 1234
    assert result.results[0].attempts == 2
    assert bus.texts().count("A005D") == 2
    assert bus.scheduler.snapshot().timeouts == 1


async def test_a_garbled_reply_to_a_query_is_sent_again(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("A0071234"))
    bus.fault(FaultKind.GARBLE)
    result = await bus.scheduler.submit("1", parse("A007D"))
    assert result.value == 1234
    assert result.results[0].attempts == 2
    counters = bus.scheduler.snapshot()
    assert counters.garbled + counters.naks + counters.checksum_errors + counters.timeouts >= 1


async def test_a_late_reply_is_its_own_commands_reply_never_the_next_ones(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("A0091234"))
    timing = bus.scheduler.timing
    frame_len, reply_len = len(b"$1A009D\r"), 12
    time_out = timing.real(timing.reply_timeout(frame_len, reply_len))
    window = timing.late_quiet(reply_len)
    # The reply leaves after the time-out, inside the quiet period that follows it.
    bus.fault(FaultKind.LATE, delay=(time_out + window / 2) * timing.scale)
    late = await bus.scheduler.submit("1", parse("A009D"))
    after = await bus.scheduler.submit("1", parse(""))
    assert late.value == 1234 and late.results[0].late
    assert after.value == StatusFlags()
    assert bus.texts() == ["A0091234", "A009D", ""]  # not sent again, not mixed up
    assert bus.scheduler.snapshot().late_replies == 1


async def test_time_outs_follow_the_baud_rate(make_bus: MakeBus) -> None:
    # The line and the scheduler at 300 bps: a query takes 32 times longer than at 9600,
    # and the scheduler waits for it.
    slow = await make_bus("1", scale=10.0, baud=300, host_latency=0.02)  # room for a loaded host
    # The first exchange of a fresh process pays for first calls (imports, coverage tracing)
    # inside its 20 ms of host margin, and a full collection of the suite's heap can take
    # longer than that: the figures are taken after a warm-up, with the collector paused.
    await slow.query("1", "")
    gc.collect()
    gc.disable()
    try:
        before = slow.scheduler.snapshot()
        for _ in range(5):
            assert (await slow.query("1", "")) == StatusFlags()
        after = slow.scheduler.snapshot()
    finally:
        gc.enable()
    assert after.exchanges - before.exchanges == 5
    assert after.timeouts == before.timeouts
    assert after.late_replies == before.late_replies
    # A scheduler that believes the line runs at 9600 gives up on the same reply too early.
    wrong = await make_bus("1", scale=10.0, baud=9600, sim_baud=300, host_latency=0.002)
    await wrong.scheduler.submit("1", parse("A010D"))
    assert wrong.scheduler.snapshot().timeouts + wrong.scheduler.snapshot().late_replies >= 1


async def test_a_request_that_cannot_start_in_time_fails_unsent(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    erase = asyncio.ensure_future(bus.scheduler.submit("1", parse("EE///")))
    await bus.sim.log.wait_for(lambda r: r.kind is RecordKind.HEARD and r.ref > 0, 0, 5.0)
    with pytest.raises(DeadlineExpired, match="could not start"):
        await bus.scheduler.submit("1", parse("OH"), priority=Priority.POLL, deadline=0.02)
    assert (await erase).outcome is Outcome.DONE
    assert "OH" not in bus.texts()


async def test_a_caller_that_went_away_is_dropped_from_the_queue(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    erase = asyncio.ensure_future(bus.scheduler.submit("1", parse("EE///")))
    await bus.sim.log.wait_for(lambda r: r.kind is RecordKind.HEARD and r.ref > 0, 0, 5.0)
    gone = asyncio.ensure_future(bus.scheduler.submit("1", parse("OL")))
    kept = asyncio.ensure_future(bus.scheduler.submit("1", parse("OS")))
    await asyncio.sleep(0)  # let both reach the queue
    assert bus.scheduler.queue_depth == 2
    gone.cancel()
    await erase
    assert (await kept).value == 300  # §16: OS factory value
    assert "OL" not in bus.texts()


async def test_identical_queued_queries_share_one_transaction(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("A0204321"))
    erase = asyncio.ensure_future(bus.scheduler.submit("1", parse("EE///")))
    await bus.sim.log.wait_for(lambda r: r.kind is RecordKind.HEARD and r.ref > 1, 0, 5.0)
    polls = [bus.scheduler.submit("1", parse("A020D"), priority=Priority.POLL) for _ in range(4)]
    operator = bus.scheduler.submit("1", parse("A020D"), priority=Priority.OPERATOR)
    other = bus.scheduler.submit("1", parse("A021D"), priority=Priority.POLL)
    results = await asyncio.gather(*polls, operator, other, erase)
    assert [r.value for r in results[:5]] == [4321] * 5
    assert bus.texts().count("A020D") == 1
    assert bus.texts().count("A021D") == 1
    assert bus.scheduler.snapshot().coalesced == 4
    # The shared request took the operator's priority: it went before the other poll.
    assert bus.texts().index("A020D") < bus.texts().index("A021D")


async def test_every_reply_and_transaction_is_published(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", [parse("OH4100"), parse("OH")], motor=2)
    observed = [e for e in bus.events if isinstance(e, ReplyObserved)]
    # F2 and its confirmation 97 are the scheduler's own frames: published all the same.
    assert [(e.command.wire(), e.value) for e in observed] == [
        ("F2", None),
        ("97", 1),
        ("OH4100", None),
        ("OH", 4100),
    ]
    assert [e.motor for e in observed[2:]] == [2, 2]
    done = [e for e in bus.events if isinstance(e, TransactionDone)]
    assert len(done) == 1
    assert tuple(c.wire() for c in done[0].commands) == ("OH4100", "OH")
    assert done[0].exchanges == 4
    assert done[0].counters.transactions == 1


async def test_a_transaction_of_stops_is_a_stop_whatever_priority_was_given(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1")
    queued: list[asyncio.Future[object]] = []

    def queue_both() -> None:
        queued.append(asyncio.ensure_future(bus.scheduler.submit("1", parse("OL"))))
        queued.append(
            asyncio.ensure_future(bus.scheduler.submit("1", parse("S"), priority=Priority.POLL))
        )

    bus.once_after("A000D", queue_both)
    await bus.scheduler.submit("1", parse("A000D"))
    await asyncio.gather(*queued)
    assert bus.texts() == ["A000D", "S", "OL"]
    with pytest.raises(TransactionError):
        await bus.scheduler.stop("1", parse("OH"))


async def test_an_error_k_would_clear_is_read_and_published_first(make_bus: MakeBus) -> None:
    # §10 K: forms I, II and IV clear the limit and EMS bits of "" without reporting them.
    bus = await make_bus("1")
    bus.controller("1").set_ems(bus.sim.now(), True)
    bus.controller("1").set_ems(bus.sim.now(), False)
    await bus.scheduler.submit("1", parse("K2,FF"))
    assert bus.texts()[-3:] == ["", "K", "K2,FF"]  # flags first, then the value pre-read
    statuses = [
        e.value
        for e in bus.events
        if isinstance(e, ReplyObserved) and isinstance(e.value, StatusFlags)
    ]
    assert statuses and statuses[-1].emergency_stop  # published, so the state cache latches it
