"""Sparkplug 3.0's Primary Host Application: with ``primary_host`` the node is born only once
the host's STATE says online, and dies (NDEATH, disconnect) when a newer STATE says offline
(in-process node on a real mosquitto; gateway/mqtt/primary_host.py)."""

from __future__ import annotations

import json
import time

import pytest

from gateway.mqtt.primary_host import PrimaryHost
from tests.mqtt.in_process import edge_node
from tests.mqtt.logs import mqtt_lines
from tests.mqtt.sparkplug_decoder import command
from tests.support.mqtt_broker import Broker, Central

STATE = "spBv1.0/STATE/scada"


def state(online: bool, timestamp: int) -> bytes:
    return json.dumps({"online": online, "timestamp": timestamp}).encode()


async def host_says(central: Central, online: bool, timestamp: int) -> None:
    """The host's STATE, retained as a host application publishes it."""
    assert central.client is not None
    await central.client.publish(STATE, state(online, timestamp), qos=1, retain=True)


async def test_births_wait_for_the_host_and_a_newer_offline_ends_the_session(
    broker: Broker, central: Central
) -> None:
    with mqtt_lines() as lines:
        async with edge_node(broker.port, connected=False, primary_host="scada") as (_, node):
            await lines.wait_for("waiting for primary host scada")
            assert central.of("fed") == []  # connected, subscribed, and not born
            online_at = int(time.time() * 1000)
            await host_says(central, True, online_at)
            birth = await central.wait_for("NBIRTH", node="fed")
            # An offline older than the online it follows is stale: ignored. A rebirth asked
            # afterwards is answered, so the node is still in its session.
            await host_says(central, False, online_at - 1000)
            mark = central.mark()
            ncmd = command(online_at, {"Node Control/Rebirth": True})
            await central.publish("spBv1.0/plant/NCMD/fed", ncmd)
            await central.wait_for("NBIRTH", node="fed", since=mark)
            await central.wait_for("DBIRTH", node="fed", device="gantry", since=mark)
            assert [m.kind for m in central.of("fed", mark)].count("NDEATH") == 0
            # A newer offline: NDEATH with the session's bdSeq, then a new session that waits.
            mark = central.mark()
            await host_says(central, False, online_at + 1000)
            death = await central.wait_for("NDEATH", node="fed", since=mark)
            assert death.values["bdSeq"] == birth.values["bdSeq"]
            await lines.wait_for("waiting for primary host scada", count=2)
            assert [m.kind for m in central.of("fed", mark)] == ["NDEATH"]
            await host_says(central, True, online_at + 2000)
            again = await central.wait_for("NBIRTH", node="fed", since=mark)
            assert again.values["bdSeq"] == (birth.values["bdSeq"] + 1) % 256
            assert node.primary is not None and node.primary.online


@pytest.mark.parametrize(
    ("payload", "rule"),
    [
        (b"online", "is not JSON"),
        (b"[true]", "a JSON object expected"),
        (b'{"online": "yes", "timestamp": 1}', "'online' must be true or false"),
        (b'{"online": true}', "'timestamp' must be ms since 1970"),
        (b'{"online": true, "timestamp": -5}', "'timestamp' must be ms since 1970"),
    ],
)
def test_a_malformed_state_is_refused_naming_the_field(payload: bytes, rule: str) -> None:
    host = PrimaryHost("scada", online=True, timestamp=10)
    with pytest.raises(ValueError, match=rule):
        host.receive(payload)
    assert (host.online, host.timestamp) == (True, 10)
