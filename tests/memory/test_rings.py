"""Rings of the recent past filled far past their bounds: count and bytes stay at the bound."""

from __future__ import annotations

import pytest

from gateway.bus.trace import TRACE_BYTES, FrameDirection, LineTrace
from gateway.rings import BoundedRing
from gateway.service import feed as feed_module
from tests.support.feed_rig import drain, make_feed, position


def test_a_ring_keeps_its_count_and_its_bytes_and_the_newest_item():
    ring: BoundedRing[bytes] = BoundedRing(5, 100, len)
    for n in range(50):
        ring.append(bytes(10) + bytes([n]))
    assert len(ring) == 5 and ring.nbytes == 55
    assert [item[-1] for item in ring] == [45, 46, 47, 48, 49]
    for _ in range(20):
        ring.append(bytes(40))
    assert (len(ring), ring.nbytes) == (2, 80)  # the bytes bind before the count
    ring.append(bytes(500))  # alone over the bytes: the newest still stays
    assert (len(ring), ring.nbytes) == (1, 500)
    assert ring.forgotten == 50 + 20 + 1 - len(ring)


def test_a_ring_refuses_a_bound_that_holds_nothing():
    with pytest.raises(ValueError, match="at least one item"):
        BoundedRing(0, 10, len)


def test_the_line_trace_keeps_its_count_of_records():
    trace = LineTrace(size=100)
    trace.enable()
    for n in range(1_000):
        trace.add(float(n), FrameDirection.TX, "1", b"$1OH\r")
    count, _ = trace.kept
    assert count == 100
    assert trace.records()[0].time == 900.0


def test_the_line_trace_keeps_its_bytes_whatever_a_noisy_line_sends():
    trace = LineTrace(size=5_000)
    trace.enable()
    for n in range(500):  # chunks of noise of 4 KiB each: 2 MiB in all
        trace.add(float(n), FrameDirection.DISCARD, None, bytes(4096), note="noise")
    count, held = trace.kept
    assert held <= TRACE_BYTES
    assert count < 260  # some 250 of 4 KiB
    assert trace.records()[-1].time == 499.0


def test_the_feeds_replay_ring_keeps_its_count():
    feed, cache = make_feed(replay=100)
    client = feed.subscribe(["axis:*"])
    for n in range(1_000):
        position(cache, "1", 1, n)
        drain(client)
    count, _ = feed.replay_kept
    assert count == 100


def test_the_feeds_replay_ring_keeps_its_bytes(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(feed_module, "REPLAY_BYTES", 20_000)  # read when a feed is made
    feed, cache = make_feed(replay=10_000)
    client = feed.subscribe(["axis:*"])
    for n in range(1_000):
        position(cache, "1", 1, n)
        drain(client)
    count, held = feed.replay_kept
    assert held <= 20_000
    assert 10 < count < 100  # views of some 700 bytes
    # a client that lost more than the ring holds gets a snapshot, as documented
    late = feed.open()
    late.subscribe(["axis:*"], since=5, stream=feed.stream)
    assert drain(late)[0]["type"] == "snapshot"
