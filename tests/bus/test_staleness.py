"""Axes turn stale exactly when their data is ``stale_after`` old, while ``refresh`` (called
after every poll) walks the axes only once the oldest fresh reading may be that old."""

from __future__ import annotations

from typing import Any

from gateway.bus.state import StateCache
from gateway.bus.state_types import Change
from tests.support.state_replies import LOOP, reply


class CountingAxes(dict[Any, Any]):
    """The cache's axes, counting the walks over them."""

    walks = 0

    def items(self) -> Any:
        self.walks += 1
        return super().items()


def _stale_changes(cache: StateCache) -> list[tuple[float, str, int | None]]:
    seen: list[tuple[float, str, int | None]] = []

    def note(change: Change) -> None:
        if change.values.get("stale") is True:
            seen.append((change.time, change.body or "", change.motor))

    cache.changes.subscribe(note)
    return seen


def test_each_axis_turns_stale_when_its_own_data_is_too_old() -> None:
    cache = StateCache(stale_after=3.0)
    reply(cache, "61", "00000000", 10.0)  # body 1 motor 1
    reply(cache, "62", "00000000", 9.0)  # body 1 motor 2: the oldest
    reply(cache, "61", "00000000", 11.0, body="2")
    stale = _stale_changes(cache)
    for now in (11.5, 12.0):  # nobody old enough yet (exactly 3.0 old: not stale)
        cache.refresh(now)
    assert stale == []
    cache.refresh(12.5)
    assert stale == [(12.5, "1", 2)]
    cache.refresh(13.0)
    assert stale == [(12.5, "1", 2)]
    cache.refresh(13.25)
    assert stale[1:] == [(13.25, "1", 1)]
    reply(cache, "62", "00000000", 13.5)  # fresh again: watched again
    cache.refresh(14.25)
    assert stale[2:] == [(14.25, "2", 1)]
    cache.refresh(16.75)
    assert stale[3:] == [(16.75, "1", 2)]
    assert all(cache.axis(LOOP, b, m).stale for b, m in (("1", 1), ("1", 2), ("2", 1)))


def test_a_poll_while_every_axis_is_fresh_walks_no_axis() -> None:
    cache = StateCache(stale_after=3.0)
    for t in (10.0, 10.5):
        reply(cache, "61", "00000000", t)
        reply(cache, "62", "00000000", t)
    cache.refresh(10.5)  # learns the oldest reading
    axes = CountingAxes(cache._axes)  # the walk is what this test is about
    cache._axes = axes
    for i in range(20):  # polls a few hundredths of a second apart, each with its reply
        now = 10.6 + i * 0.1
        reply(cache, "61", "00000000", now)
        reply(cache, "62", "00000000", now)
        cache.refresh(now)
    assert axes.walks == 0
    assert not cache.axis(LOOP, "1", 1).stale
    cache.refresh(12.5 + 3.0 + 0.01)  # the newest reading was at 12.5
    assert axes.walks >= 1 and cache.axis(LOOP, "1", 1).stale
