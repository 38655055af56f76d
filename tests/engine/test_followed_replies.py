"""The worker relays reply events only for the controllers its client follows (those an
operation watches), once told; a transaction's end and the state's changes cross whatever it
follows, so an idle poll of an unwatched controller costs the channel one message."""

from __future__ import annotations

from gateway.bus.events import BusEvent, ReplyObserved, TransactionDone
from gateway.protocol.command_text import parse
from gateway.service.events import EventKind, ServiceEvent, ServiceEvents
from gateway.service.runtime.followed import FollowedControllers
from tests.support.engine_rig import Attach, MakeBus


async def test_reply_events_cross_for_followed_controllers_only(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus)
    client = linked.client
    proxy = client.proxies[bus.scheduler.name]
    seen: list[BusEvent] = []
    proxy.events.subscribe(seen.append)

    await proxy.submit("1", parse("A005D"))  # before it says: every reply crosses
    assert [type(e) for e in seen if isinstance(e, ReplyObserved)] == [ReplyObserved]

    client.follow(frozenset())
    seen.clear()
    result = await proxy.submit("1", [parse("A0051234"), parse("A005D")])
    assert result.value == 1234  # the request's own result is whole
    assert not [e for e in seen if isinstance(e, ReplyObserved)]
    assert [e for e in seen if isinstance(e, TransactionDone)]  # its end crosses

    client.follow(frozenset({(proxy.name, "1")}))
    seen.clear()
    await proxy.submit("1", parse("A005D"))
    replies = [e for e in seen if isinstance(e, ReplyObserved)]
    assert [(e.body, e.value) for e in replies] == [("1", 1234)]


def _operation(axis: str, state: str) -> ServiceEvent:
    return ServiceEvent(EventKind.OPERATION, f"axis:{axis}", 0.0, {"axis": axis, "state": state})


def test_a_controller_is_followed_while_its_latest_operation_is_not_over() -> None:
    events = ServiceEvents()
    told: list[frozenset[tuple[str, str]]] = []
    FollowedControllers(events, told.append).start()
    events.publish(_operation("main.1.1", "queued"))
    events.publish(_operation("main.1.1", "moving"))  # no news: not told again
    events.publish(_operation("side.2.2", "sent"))
    events.publish(_operation("main.1.1", "unknown"))  # its read-back reads the replies
    events.publish(_operation("main.1.1", "done"))
    events.publish(_operation("side.2.2", "failed"))
    assert told == [
        frozenset(),
        frozenset({("main", "1")}),
        frozenset({("main", "1"), ("side", "2")}),
        frozenset({("side", "2")}),
        frozenset(),
    ]
