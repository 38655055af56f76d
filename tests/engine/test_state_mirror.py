"""The mirror applies a worker's changes only in their order: a missed one leaves it as it was
until a snapshot comes; several workers number their changes apart."""

from __future__ import annotations

from types import MappingProxyType

from gateway.bus.state import StateCache
from gateway.bus.state_types import Change
from gateway.engine.mirror import StateMirror


def _worker_cache(loop: str) -> tuple[StateCache, list[Change]]:
    cache = StateCache()
    changes: list[Change] = []
    cache.changes.subscribe(changes.append)
    cache.write_axis(1.0, loop, "1", 1, position=100)
    return cache, changes


def test_a_gap_is_refused_and_a_snapshot_heals_it() -> None:
    cache, changes = _worker_cache("a")
    mirror = StateMirror()
    assert not mirror.apply("w0", changes[0])  # no snapshot yet: nothing to apply it to
    mirror.load("w0", cache.snapshot())
    assert mirror.axis("a", "1", 1).position == 100
    cache.write_axis(2.0, "a", "1", 1, position=200)
    cache.write_axis(3.0, "a", "1", 1, position=300)
    assert not mirror.apply("w0", changes[-1])  # 200 was missed
    assert mirror.axis("a", "1", 1).position == 100
    assert mirror.apply("w0", changes[-2]) and mirror.apply("w0", changes[-1])
    assert mirror.axis("a", "1", 1).position == 300


def test_two_workers_feed_one_sequence() -> None:
    a, a_changes = _worker_cache("a")
    b, b_changes = _worker_cache("b")
    mirror = StateMirror()
    published: list[Change] = []
    mirror.changes.subscribe(published.append)
    mirror.load("wa", a.snapshot())
    mirror.load("wb", b.snapshot())
    a.write_axis(2.0, "a", "1", 1, position=7)
    b.write_axis(2.0, "b", "1", 1, position=8)
    assert mirror.apply("wa", a_changes[-1]) and mirror.apply("wb", b_changes[-1])
    assert [c.seq for c in published] == list(range(1, len(published) + 1))
    assert published[-1].values == MappingProxyType({"position": 8})
    assert (mirror.axis("a", "1", 1).position, mirror.axis("b", "1", 1).position) == (7, 8)
