"""The feed without a server: numbering, the replay ring, dropping, what is not published."""

from __future__ import annotations

import json

from gateway.protocol.framing import POWER_ON
from tests.support.feed_rig import drain, make_feed, position


def test_messages_carry_the_feeds_number_and_the_wall_clock() -> None:
    feed, cache = make_feed()
    client = feed.subscribe(["axis:sim.1.1"])
    position(cache, "1", 1, 10)
    snapshot, change = drain(client)
    # seq 1: the controller came online (not subscribed); seq 2: the axis.
    assert snapshot["seq"] == 0 and change["seq"] == 2 == feed.seq
    assert change["time"] == 1_700_000_000.25
    assert change["state_seq"] == cache.seq  # the cache numbers its own changes
    assert change["data"]["position"] == 10


def test_a_client_whose_queue_overflows_is_dropped_and_the_others_go_on() -> None:
    feed, cache = make_feed()
    slow, fast = feed.open(backlog=3), feed.open()
    slow.subscribe(["axis:x"])  # the snapshot: 1 of 3
    fast.subscribe(["axis:x"])
    for pulses in range(1, 5):
        position(cache, "1", 1, pulses)
    assert slow.dropped and slow.ended.is_set() and slow.pending == 3
    assert feed.dropped == 1 and feed.clients == 1
    position(cache, "1", 1, 5)
    assert slow.pending == 3  # nothing more for it
    got = [m["data"]["position"] for m in drain(fast) if m["type"] == "change"]
    assert got == [1, 2, 3, 4, 5]


def test_a_change_no_client_can_see_is_not_published() -> None:
    feed, cache = make_feed()
    client = feed.subscribe(["controller:*"])
    position(cache, "1", 1, 10)  # the controller goes online: a change
    drain(client)
    seq, state_seq = feed.seq, cache.seq
    # The framing is the cache's, not part of the controller's view (§10 EE, EL, ER, SUM).
    cache.set_framing("sim", "1", POWER_ON.__class__(echo=True), 2.0)
    assert cache.seq == state_seq + 1
    assert feed.seq == seq and client.pending == 0


def test_a_controller_the_configuration_does_not_name_is_ignored() -> None:
    feed, cache = make_feed()
    client = feed.subscribe(["axis:*", "controller:*"])
    position(cache, "7", 1, 10)  # body 7 is not configured
    assert feed.seq == 0 and len(drain(client)) == 1  # the snapshot alone


def test_a_replay_longer_than_the_backlog_is_a_snapshot() -> None:
    feed, cache = make_feed(backlog=10)
    for pulses in range(1, 21):
        position(cache, "1", 1, pulses)
    client = feed.open()
    client.subscribe(["axis:x"], since=0)  # 20 missed: more than the queue holds
    (answer,) = drain(client)
    assert answer["type"] == "snapshot" and answer["axes"][0]["position"] == 20
    assert not client.dropped


def test_replay_gives_only_the_new_topics_and_the_ring_is_bounded() -> None:
    feed, cache = make_feed(replay=100)
    position(cache, "1", 1, 1)
    position(cache, "1", 2, 2)
    client = feed.open()
    client.subscribe(["axis:y"], since=0)
    replayed = drain(client)
    assert [m["topic"] for m in replayed if m["type"] == "change"] == ["axis:sim.1.2"]
    assert replayed[-1]["type"] == "subscribed" and replayed[-1]["replayed"] == 1
    for pulses in range(3, 250):
        position(cache, "1", 1, pulses)
    late = feed.open()
    late.subscribe(["axis:x"], since=1)  # message 2 is long gone
    assert drain(late)[0]["type"] == "snapshot"


def test_close_stops_the_feed_and_ends_every_client() -> None:
    feed, cache = make_feed()
    client = feed.subscribe(["axis:x"])
    feed.close()
    position(cache, "1", 1, 10)
    assert client.ended.is_set() and not client.dropped
    assert feed.seq == 0


def test_a_message_is_encoded_once_for_every_client() -> None:
    feed, cache = make_feed()
    clients = [feed.subscribe(["axis:x"]) for _ in range(3)]
    for c in clients:
        drain(c)
    position(cache, "1", 1, 10)
    texts = [c.get_nowait() for c in clients]
    assert texts[0] is texts[1] is texts[2]
    assert json.loads(texts[0])["data"]["position"] == 10
