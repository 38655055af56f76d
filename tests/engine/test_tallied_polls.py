"""An idle poll of a controller nobody follows sends nothing across the worker channel at
once: its ``TransactionDone`` crosses in the loop's tally, one message a period, and every
transaction is still counted there within that period."""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from gateway.bus.events import BusEvent, TransactionDone, TransactionsTallied
from gateway.bus.poll_plan import PollConfig
from gateway.bus.requests import Priority
from gateway.engine.tally import TALLY_PERIOD
from gateway.protocol.command_text import parse
from tests.support.engine_rig import Attach, Linked, MakeBus


class Seen:
    """The events the client's proxy publishes, with a wait on a condition over them."""

    def __init__(self, linked: Linked) -> None:
        self.events: list[BusEvent] = []
        self._changed = asyncio.Event()
        proxy = linked.proxy
        proxy.events.subscribe(self._take)

    def _take(self, event: BusEvent) -> None:
        self.events.append(event)
        self._changed.set()

    async def until(self, check: Callable[[], bool], timeout: float) -> None:
        async with asyncio.timeout(timeout):
            while not check():
                self._changed.clear()
                await self._changed.wait()

    def polls_alone(self) -> list[TransactionDone]:
        return [
            e for e in self.events if isinstance(e, TransactionDone) and e.priority is Priority.POLL
        ]

    def tallies(self) -> list[TransactionsTallied]:
        return [e for e in self.events if isinstance(e, TransactionsTallied)]

    def counted(self) -> int:
        """Transactions the client heard of: one by one, or in a tally."""
        alone = sum(isinstance(e, TransactionDone) for e in self.events)
        return alone + sum(len(t.tallies) for t in self.tallies())


async def _follow(linked: Linked, followed: frozenset[tuple[str, str]]) -> None:
    """Tell the worker whom the client follows; a request after it proves it arrived (the
    channel keeps the order)."""
    proxy = linked.proxy
    linked.client.follow(followed)
    await proxy.submit("1", parse("A005D"))


async def test_idle_polls_of_an_unfollowed_controller_cross_in_one_tally_a_period(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus, PollConfig(idle_period=0.05))
    proxy = linked.proxy
    await _follow(linked, frozenset())
    seen = Seen(linked)
    before = bus.scheduler.counters.transactions

    await proxy.polling(True)
    await seen.until(lambda: seen.counted() >= 4, 8 * TALLY_PERIOD)
    await proxy.polling(False)
    done = bus.scheduler.counters.transactions - before

    assert seen.polls_alone() == []  # no poll crossed on its own
    # every poll is counted within one period of its end, with its figures
    await seen.until(lambda: seen.counted() == done, 4 * TALLY_PERIOD)
    rows = [row for tally in seen.tallies() for row in tally.tallies]
    assert len(rows) == done
    assert len(seen.tallies()) < len(rows)  # fewer messages than transactions
    assert {(row.body, row.priority, str(row.outcome)) for row in rows} == {
        ("1", Priority.POLL, "done")
    }
    assert all(row.duration > 0 and row.exchanges >= 1 for row in rows)
    # the counters the client shows are the worker's, as of the last tallied poll
    assert proxy.snapshot() == bus.scheduler.snapshot()


async def test_a_request_and_a_followed_controllers_polls_cross_at_once(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus, PollConfig(idle_period=0.05))
    proxy = linked.proxy
    await _follow(linked, frozenset({(proxy.name, "1")}))
    seen = Seen(linked)

    await proxy.polling(True)
    await seen.until(lambda: len(seen.polls_alone()) >= 2, 4 * TALLY_PERIOD)
    await proxy.polling(False)
    assert seen.tallies() == []  # a followed controller's polls are read by an operation

    await _follow(linked, frozenset())
    seen.events.clear()
    await proxy.polling(True)
    await seen.until(lambda: bool(seen.tallies()), 4 * TALLY_PERIOD)
    await proxy.polling(False)
    # a caller's transaction crosses at once, after the tally of the polls before it
    await proxy.submit("1", parse("A005D"))
    asked = [e for e in seen.events if isinstance(e, TransactionDone)]
    assert [e.priority for e in asked] == [Priority.OPERATOR]
    last_tally = max(i for i, e in enumerate(seen.events) if isinstance(e, TransactionsTallied))
    assert seen.events.index(asked[0]) > last_tally
