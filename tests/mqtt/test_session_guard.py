"""The edge node against what others send it: oversized payloads and a second node with its
Sparkplug id (in-process nodes on a real mosquitto; gateway/mqtt/session_guard.py)."""

from __future__ import annotations

import asyncio
import logging
import time

from tests.mqtt.in_process import edge_node
from tests.mqtt.logs import mqtt_lines
from tests.mqtt.sparkplug_decoder import command
from tests.support.mqtt_broker import Broker, Central

NCMD = "spBv1.0/plant/NCMD/fed"


def now() -> int:
    return int(time.time() * 1000)


async def test_an_oversized_payload_is_dropped_unread_counted_and_logged_once(
    broker: Broker, central: Central
) -> None:
    with mqtt_lines() as lines:
        async with edge_node(broker.port) as (_, node):
            await central.wait_for("NBIRTH", node="fed")
            mark = central.mark()
            padding: dict[str, bool | str] = {f"Pad/{i}": "x" * 100 for i in range(1000)}
            big = command(now(), {"Node Control/Rebirth": True, **padding})
            assert len(big) > 64 * 1024
            for _ in range(3):
                await central.publish(NCMD, big)
            await central.wait_for(
                "NDATA", node="fed", since=mark,
                where=lambda m: m.values.get("MQTT/Dropped Payloads") == 3,
            )  # fmt: skip
            # The rebirth it asked for was never read; a small one is.
            assert [m.kind for m in central.of("fed", mark) if m.kind == "NBIRTH"] == []
            await central.publish(NCMD, command(now(), {"Node Control/Rebirth": True}))
            rebirth = await central.wait_for("NBIRTH", node="fed", since=mark)
            assert rebirth.values["MQTT/Dropped Payloads"] == 3
            assert node.payloads.dropped == 3
    dropped = lines.having("dropped unread")
    assert len(dropped) == 1 and dropped[0].levelno == logging.WARNING
    assert "over 65536 bytes" in dropped[0].getMessage()


async def test_a_second_node_with_the_same_id_is_named_counted_and_backed_off_from(
    broker: Broker, central: Central
) -> None:
    fast = {"reconnect_min": 0.2, "reconnect_max": 1.0}
    with mqtt_lines() as lines:
        async with edge_node(broker.port, **fast) as (_, first):
            await central.wait_for("NBIRTH", node="fed")
            started = central.mark()
            # Same group, edge node id and so client id: each takes the other's session.
            async with edge_node(broker.port, connected=False, **fast) as (_, second):
                await lines.wait_for("is used by another node", count=2)
                # Watch them for 6 s: reconnecting at reconnect_min they would be born ~40
                # times; backing off doubling from takeover to takeover, about 10.
                await asyncio.sleep(6)
                births = [m for m in central.of("fed", started) if m.kind == "NBIRTH"]
                takeovers = first.takeovers + second.takeovers
    assert first.takeovers >= 1 and second.takeovers >= 1
    assert len(births) <= 16, f"{len(births)} NBIRTH in 6 s"
    assert takeovers <= 16, takeovers
    errors = lines.having("is used by another node")
    assert all(r.levelno == logging.ERROR for r in errors)
    text = errors[0].getMessage()
    assert "plant/fed" in text and "rc233-plant-fed" in text and "sessions in a row" in text
    # The count goes out with the node's metrics.
    assert max(m.values.get("MQTT/Takeovers") or 0 for m in births) >= 1


async def test_an_nbirth_of_another_client_on_our_id_ends_our_session(
    broker: Broker, central: Central
) -> None:
    with mqtt_lines() as lines:
        async with edge_node(broker.port, client_id="gw-a") as (_, node):
            await central.wait_for("NBIRTH", node="fed")
            mark = central.mark()
            # Someone else (another client id) publishes a birth as plant/fed.
            await central.publish("spBv1.0/plant/NBIRTH/fed", command(now(), {"bdSeq": "x"}))
            death = await central.wait_for("NDEATH", node="fed", since=mark)
            await lines.wait_for("an NBIRTH of another node")
            assert node.takeovers == 1
            assert death.payload.seq is None
    error = lines.having("an NBIRTH of another node")[0]
    assert error.levelno == logging.ERROR and "plant/fed" in error.getMessage()
