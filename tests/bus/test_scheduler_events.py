"""The publish/subscribe of the scheduler's events, and replies that carry no answer."""

from __future__ import annotations

from gateway.bus.events import BusEvent, EventBus, LinkUp, ReplyObserved
from gateway.bus.requests import Outcome, ReplyKind
from gateway.protocol.command_text import parse
from gateway.sim.faults import FaultKind
from tests.support.bus_rig import MakeBus


def test_callbacks_get_every_event_in_order() -> None:
    bus: EventBus[BusEvent] = EventBus()
    seen: list[BusEvent] = []
    unsubscribe = bus.subscribe(seen.append)
    bus.subscribe(lambda e: [][0])  # a failing subscriber stops nobody
    events = [LinkUp(loop="a", time=float(n)) for n in range(3)]
    for event in events:
        bus.publish(event)
    assert seen == events
    unsubscribe()
    bus.publish(LinkUp(loop="b"))
    assert len(seen) == 3


def test_a_first_subscriber_runs_before_those_that_subscribed_earlier() -> None:
    # The state cache subscribes first: every other subscriber reads what the event taught it.
    bus: EventBus[BusEvent] = EventBus()
    order: list[str] = []
    bus.subscribe(lambda _e: order.append("early"))
    bus.subscribe(lambda _e: order.append("cache"), first=True)
    bus.subscribe(lambda _e: order.append("late"))
    bus.publish(LinkUp(loop="a"))
    assert order == ["cache", "early", "late"]


async def test_a_lost_reply_to_a_read_that_clears_flags_is_not_sent_again(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1")
    bus.fault(FaultKind.DROP)
    result = await bus.scheduler.submit("1", parse(""))
    # §10 "": the read cleared the error bits it reported; sending it again would report
    # none of them, so it is not resent and the caller learns the value is lost. The bits
    # are read from the other store instead (9 form I, §10 9 ③).
    assert result.outcome is Outcome.UNKNOWN
    assert result.results[0].kind is ReplyKind.TIMEOUT
    assert bus.texts() == ["", "9"]


async def test_a_query_the_controller_refused_is_not_done(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("7"), motor=1)  # jog motor 1
    # §10 CLM: not while moving; the device answers a refused query with a bare '>'
    result = await bus.scheduler.submit("1", parse("CLM2"))
    assert result.outcome is Outcome.NOT_DONE
    assert result.results[0].kind is ReplyKind.ACCEPTED and result.value is None
    await bus.scheduler.stop("1")
    await bus.wait_idle()


async def test_a_checksum_mismatch_is_sent_again(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", [parse("EL1"), parse("SUM1"), parse("A0115555")])
    bus.fault(FaultKind.GARBLE, shots=2)  # two replies garbled: the third attempt gets through
    assert (await bus.query("1", "A011D")) == 5555
    counters = bus.scheduler.snapshot()
    assert counters.checksum_errors + counters.garbled + counters.naks >= 1
    replies = [e for e in bus.events if isinstance(e, ReplyObserved) and e.command.key == "A{pn}D"]
    assert [e.value for e in replies] == [5555]  # nothing wrong was ever published


async def test_an_absent_controller_is_probed_once_per_link_up(make_bus: MakeBus) -> None:
    bus = await make_bus("1", sum_at_connect=True, resend_retries=0)
    for _ in range(2):
        result = await bus.scheduler.submit("5", parse("A000D"))
        assert result.outcome is Outcome.UNKNOWN
    # the framing probes went out once; then the command alone, each time
    texts = bus.texts("5")
    assert texts.count("SUM") >= 1 and texts.count("A000D") == 2
    assert texts[-1] == "A000D" and texts[-2] == "A000D"
