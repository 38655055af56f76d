"""The WebSocket feed through a real server: snapshot, changes, resume, events, errors, auth.

The cache behind the server is fed as the loop scheduler feeds it (a decoded ``6{mt}`` reply,
§10 6), so each test knows exactly which positions the axes reported. Axis ``x`` is
``sim.1.1`` at 0.01 mm a pulse (gateway/service/runtime/simulated.py).
"""

from __future__ import annotations

from typing import Any

import pytest
from websockets.exceptions import ConnectionClosed

from gateway.service.events import EventKind, ServiceEvent
from tests.support.ws_server import MakeWsServer, WsClient, WsServer


async def changes(client: WsClient, count: int) -> list[dict[str, Any]]:
    return [await client.recv() for _ in range(count)]


async def test_subscribe_gives_a_snapshot_then_the_changes_in_order(
    make_ws_server: MakeWsServer,
) -> None:
    server = await make_ws_server()
    server.position("1", 1, 500)  # before the client: in the snapshot, not as a change
    client = await server.connect()

    snapshot = await client.subscribe("axis:x")  # by name; answered with the id

    assert snapshot["type"] == "snapshot"
    assert snapshot["topics"] == ["axis:sim.1.1"]
    assert [a["id"] for a in snapshot["axes"]] == ["sim.1.1"]
    assert snapshot["axes"][0]["name"] == "x"
    assert snapshot["axes"][0]["position"] == 500
    assert snapshot["axes"][0]["position_user"] == 5.0  # 500 pulses of 0.01 mm
    assert snapshot["controllers"] == [] and snapshot["loops"] == []

    for pulses in (1000, 2000):
        server.position("1", 1, pulses)
        server.position("1", 2, pulses + 1)  # axis y: not subscribed, never delivered
    server.position("1", 1, 12345)
    got = await changes(client, 3)

    assert [m["type"] for m in got] == ["change"] * 3
    assert [m["topic"] for m in got] == ["axis:sim.1.1"] * 3
    assert [m["data"]["position"] for m in got] == [1000, 2000, 12345]
    assert got[-1]["data"]["position_user"] == 123.45
    assert "position" in got[0]["changed"] and "position_user" in got[0]["changed"]
    seqs = [snapshot["seq"]] + [m["seq"] for m in got]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)
    state_seqs = [m["state_seq"] for m in got]
    assert state_seqs == sorted(state_seqs)
    # A ping is answered after everything queued before it: nothing of y slipped in.
    await client.send({"type": "ping", "id": 7})
    pong = await client.recv()
    assert pong == {"type": "pong", "id": 7, "seq": pong["seq"], "time": pong["time"]}
    assert pong["seq"] >= got[-1]["seq"]


async def test_wildcards_and_controllers_and_a_second_subscribe(
    make_ws_server: MakeWsServer,
) -> None:
    server = await make_ws_server()
    client = await server.connect()
    snapshot = await client.subscribe("axis:*")
    assert [a["id"] for a in snapshot["axes"]] == ["sim.1.1", "sim.1.2", "sim.2.1", "sim.2.2"]

    server.position("2", 2, 90)  # theta
    change = await client.recv()
    assert (change["topic"], change["data"]["name"]) == ("axis:sim.2.2", "theta")

    snapshot = await client.subscribe("controller:head")
    assert snapshot["topics"] == ["controller:sim.2"]
    assert [c["id"] for c in snapshot["controllers"]] == ["sim.2"]
    assert snapshot["controllers"][0]["online"] is True  # the reply above: it answers
    assert snapshot["axes"] == []  # the axes were subscribed already


async def test_unsubscribe_stops_the_topic(make_ws_server: MakeWsServer) -> None:
    server = await make_ws_server()
    client = await server.connect()
    await client.subscribe("axis:x", "axis:y")
    await client.send({"type": "unsubscribe", "topics": ["axis:x"]})
    ack = await client.recv()
    assert (ack["type"], ack["topics"]) == ("unsubscribed", ["axis:sim.1.1"])
    server.position("1", 1, 10)  # x: no longer delivered
    server.position("1", 2, 20)
    change = await client.recv()
    assert (change["topic"], change["data"]["position"]) == ("axis:sim.1.2", 20)


async def test_reconnect_with_the_last_seq_gets_what_was_missed(
    make_ws_server: MakeWsServer,
) -> None:
    server = await make_ws_server()
    client = await server.connect()
    snapshot = await client.subscribe("axis:x")
    server.position("1", 1, 100)
    seen = await client.recv()
    await client.close()

    for pulses in (200, 300, 400):
        server.position("1", 1, pulses)
    server.position("1", 2, 999)  # y: not one of the client's topics

    again = await server.connect()
    await again.send(
        {
            "type": "subscribe",
            "topics": ["axis:x"],
            "since": seen["seq"],
            "stream": snapshot["stream"],
        }
    )
    missed = await changes(again, 3)
    assert [m["data"]["position"] for m in missed] == [200, 300, 400]
    assert all(m["seq"] > seen["seq"] for m in missed)
    ack = await again.recv()
    assert ack["type"] == "subscribed"
    assert (ack["topics"], ack["replayed"]) == (["axis:sim.1.1"], 3)
    server.position("1", 1, 500)  # then live
    live = await again.recv()
    assert live["data"]["position"] == 500 and live["seq"] > missed[-1]["seq"]


async def test_a_seq_older_than_the_replay_buffer_gets_a_snapshot(
    make_ws_server: MakeWsServer,
) -> None:
    server = await make_ws_server(replay=100)
    client = await server.connect()
    await client.subscribe("axis:x")
    server.position("1", 1, 1)
    last = (await client.recv())["seq"]
    await client.close()
    for pulses in range(2, 200):  # 198 changes: more than the 100 the feed keeps
        server.position("1", 1, pulses)

    again = await server.connect()
    answer = await again.subscribe("axis:x", since=last)
    assert answer["type"] == "snapshot"
    assert answer["axes"][0]["position"] == 199
    assert answer["seq"] == server.feed.seq


async def test_a_seq_of_another_stream_gets_a_snapshot(make_ws_server: MakeWsServer) -> None:
    # The gateway restarted: its numbers mean nothing to the client any more.
    server = await make_ws_server()
    server.position("1", 1, 42)
    client = await server.connect()
    answer = await client.subscribe("axis:x", since=0, stream="0badbeef")
    assert answer["type"] == "snapshot" and answer["axes"][0]["position"] == 42


async def test_events_reach_event_and_resource_subscribers(make_ws_server: MakeWsServer) -> None:
    server = await make_ws_server()
    ops = await server.connect()
    axis = await server.connect()
    other = await server.connect()
    await ops.subscribe("event:operation")
    await axis.subscribe("axis:x")
    await other.subscribe("event:link")

    data = {"id": "op-1", "state": "moving", "axis": "sim.1.1"}
    server.events.publish(ServiceEvent(EventKind.OPERATION, "axis:sim.1.1", 1.7e9, data))
    server.events.publish(ServiceEvent(EventKind.LINK, "loop:sim", 1.7e9, {"up": False}))

    event = await ops.recv()
    assert (event["type"], event["kind"], event["topic"]) == (
        "event",
        "operation",
        "event:operation",
    )
    assert (event["resource"], event["data"]) == ("axis:sim.1.1", data)
    assert (await axis.recv())["data"] == data
    link = await other.recv()
    assert (link["kind"], link["data"]) == ("link", {"up": False})


@pytest.mark.parametrize(
    ("message", "field"),
    [
        ("not json", None),
        ('["subscribe"]', None),
        ({"type": "subscribe"}, "topics"),
        ({"type": "subscribe", "topics": []}, "topics"),
        ({"type": "subscribe", "topics": ["axis:nope"]}, "topics[0]"),
        ({"type": "subscribe", "topics": ["axis:x", "bogus"]}, "topics[1]"),
        ({"type": "subscribe", "topics": ["event:nothing"]}, "topics[0]"),
        ({"type": "subscribe", "topics": ["axis:x"], "since": -1}, "since"),
        ({"type": "subscribe", "topics": ["axis:x"], "sinse": 3}, "sinse"),
        ({"type": "subscribe", "topics": [5]}, "topics[0]"),
        ({"type": "watch", "topics": ["axis:x"]}, "type"),
        ({"topics": ["axis:x"]}, "type"),
        ({"type": "unsubscribe", "topics": ["controller:9.9"]}, "topics[0]"),
    ],
)
async def test_a_bad_message_is_answered_with_an_error_naming_the_field(
    make_ws_server: MakeWsServer, message: dict[str, Any] | str, field: str | None
) -> None:
    server = await make_ws_server()
    client = await server.connect()
    await client.send(message)
    error = await client.recv()
    assert error["type"] == "error"
    assert error["field"] == field
    assert error["rule"] and error["detail"]
    # The connection stays usable and nothing was subscribed.
    server.position("1", 1, 5)
    await client.send({"type": "ping", "id": "after"})
    assert (await client.recv())["type"] == "pong"


async def test_the_topic_error_says_what_a_topic_is(make_ws_server: MakeWsServer) -> None:
    server = await make_ws_server()
    client = await server.connect()
    error = await client.subscribe("axis:nope")
    assert "axis:<id|name>" in error["rule"] and "nope" in error["detail"]


@pytest.mark.parametrize("token", [None, "wrong-token"])
async def test_without_a_known_token_the_socket_closes_with_4401(
    make_ws_server: MakeWsServer, token: str | None
) -> None:
    server = await make_ws_server()
    client = await server.connect(token)
    with pytest.raises(ConnectionClosed) as closed:
        await client.recv()
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 4401
    assert server.stats.connected_total == 0


async def test_the_token_in_the_authorization_header(make_ws_server: MakeWsServer) -> None:
    from tests.support.ws_server import VIEWER_TOKEN

    server = await make_ws_server()
    client = await server.connect(
        None, additional_headers={"Authorization": f"Bearer {VIEWER_TOKEN}"}
    )
    assert (await client.subscribe("loop:sim"))["loops"][0]["name"] == "sim"


async def test_shutdown_closes_clients_with_1001(make_ws_server: MakeWsServer) -> None:
    server: WsServer = await make_ws_server()
    client = await server.connect()
    await client.subscribe("axis:x")
    server.feed.close()
    with pytest.raises(ConnectionClosed) as closed:
        await client.recv()
    assert closed.value.rcvd is not None and closed.value.rcvd.code == 1001
