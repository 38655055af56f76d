"""EEPROM writes hold the line until ``$B#*`` (§10 AW, DW, IW, EE///); unsolicited messages
are events, never replies.
"""

from __future__ import annotations

import asyncio

from gateway.bus.events import ReplyObserved, UnsolicitedMessage
from gateway.bus.requests import Outcome, ReplyKind
from gateway.protocol import commands as cmd
from gateway.protocol.command_text import parse
from gateway.protocol.reply_parser import UnsolicitedKind
from gateway.sim.clock import RecordKind
from gateway.sim.faults import FaultKind
from tests.support.bus_rig import MakeBus


async def test_dw_holds_the_line_until_its_message(make_bus: MakeBus) -> None:
    bus = await make_bus("12")
    others: list[asyncio.Future[object]] = []

    def queue_others() -> None:
        others.append(asyncio.ensure_future(bus.scheduler.submit("2", parse("OH"))))
        others.append(asyncio.ensure_future(bus.scheduler.submit("1", parse("A000D"))))

    bus.once_after("DW", queue_others)
    result = await bus.scheduler.submit("1", parse("DW"))
    values = await asyncio.gather(*others)
    assert result.outcome is Outcome.DONE and result.results[0].seen["eeprom_done"] is True
    assert [v.value for v in values] == [5000, 0]  # type: ignore[attr-defined]
    # §10 DW: '>' at once, '$1*' CR when the write ends; nothing else is sent in between.
    records = [
        r for r in bus.records() if r.kind in (RecordKind.HEARD, RecordKind.REPLY, RecordKind.LATER)
    ]
    kinds = [(r.kind, r.data) for r in records]
    assert kinds[:3] == [
        (RecordKind.HEARD, b"$1DW\r"),
        (RecordKind.REPLY, b">"),
        (RecordKind.LATER, b"$1*\r"),
    ]
    messages = [e for e in bus.events if isinstance(e, UnsolicitedMessage)]
    assert [(m.body, m.kind, m.data) for m in messages] == [("1", UnsolicitedKind.EEPROM_DONE, "*")]


async def test_a_stop_still_goes_out_during_an_erase(make_bus: MakeBus) -> None:
    bus = await make_bus("12")
    queued: list[asyncio.Future[object]] = []

    def queue_stop_and_poll() -> None:
        queued.append(asyncio.ensure_future(bus.scheduler.submit("2", parse("A000D"))))
        queued.append(asyncio.ensure_future(bus.scheduler.stop("2", cmd.slow_stop())))

    bus.once_after("EE///", queue_stop_and_poll)
    erase = await bus.scheduler.submit("1", parse("EE///"))
    poll, stop = await asyncio.gather(*queued)
    assert erase.outcome is Outcome.DONE
    assert stop.outcome is Outcome.DONE  # type: ignore[attr-defined]
    assert poll.value == 0  # type: ignore[attr-defined]
    sequence = [
        r.data for r in bus.records() if r.kind in (RecordKind.HEARD, RecordKind.LATER) and r.data
    ]
    # §10 EE///: erasing takes up to 20 s; the stop goes out meanwhile, the poll after '$1*'.
    assert sequence == [b"$1EE///\r", b"$2SS\r", b"$1*\r", b"$2A000D\r"]


async def test_a_lost_reply_to_dw_is_decided_by_its_message(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    bus.fault(FaultKind.DROP)
    result = await bus.scheduler.submit("1", parse("DW"))
    step = result.results[0]
    assert step.kind is ReplyKind.TIMEOUT
    assert step.outcome is Outcome.DONE and step.seen["eeprom_done"] is True
    assert bus.texts() == ["DW"]  # an EEPROM write is never sent again blindly


async def test_unsolicited_messages_never_satisfy_a_pending_reply(make_bus: MakeBus) -> None:
    bus = await make_bus("12")
    values = []
    timer_seen = asyncio.Event()

    def watch(event: object) -> None:
        if isinstance(event, UnsolicitedMessage) and event.kind is UnsolicitedKind.TIMER_UP:
            timer_seen.set()

    # Watch first: at this time scale the time-up may come before the caller runs again.
    bus.scheduler.events.subscribe(watch)
    # §10 T: T{time} answers '>' and sends '$1T' at time-up, whenever that is.
    await bus.scheduler.submit("1", parse("T50"))  # 5 s: time for many replies meanwhile
    while not timer_seen.is_set():
        result = await bus.scheduler.submit("2", parse("OH"))
        values.append(result.value)
        assert len(values) < 5000
    assert values and set(values) == {5000}
    replies = [e for e in bus.events if isinstance(e, ReplyObserved) and e.body == "2"]
    assert all(e.value == 5000 for e in replies)
    messages = [e for e in bus.events if isinstance(e, UnsolicitedMessage)]
    assert [(m.body, m.data) for m in messages] == [("1", "T")]


async def test_a_write_message_after_the_hold_is_an_event_not_a_reply(make_bus: MakeBus) -> None:
    # A hold shorter than the write: the line is released before '$1*' comes, and the
    # queries sent meanwhile get their own replies. At a time scale of 5 the write (1.5 s)
    # outlasts the hold by 0.3 real seconds, so a busy host cannot let '$1*' in before it ends.
    bus = await make_bus("12", scale=5.0, eeprom_write_hold=0.05, host_latency=0.003)
    result = await bus.scheduler.submit("1", parse("AW"))
    assert result.outcome is Outcome.UNKNOWN
    assert result.results[0].seen["eeprom_done"] is False
    values = []
    while not [e for e in bus.events if isinstance(e, UnsolicitedMessage)]:
        values.append((await bus.scheduler.submit("2", parse("OL"))).value)
        assert len(values) < 5000
    assert set(values) == {500}
    later = [r for r in bus.records(RecordKind.LATER)]
    assert [r.data for r in later] == [b"$1*\r"]
