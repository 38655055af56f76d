"""``seq`` and the bounded queue, on the edge node in-process and a real mosquitto.

The state cache is fed the way the loop scheduler feeds it (``StateCache.handle`` of
``ReplyObserved``, as tests/support/ws_server.py does), so the test decides how many changes
happen: 300 positions give 300 DDATA, past 255 -> 0.
"""

from __future__ import annotations

from gateway.bus.events import ReplyObserved
from gateway.protocol.command_text import parse
from gateway.service.runtime.runtime import Runtime
from gateway.service.runtime.simulated import SIM_LOOP
from tests.mqtt.in_process import edge_node
from tests.support.mqtt_broker import Broker, Central, seqs_in_order


def position(gateway: Runtime, pulses: int, at: float) -> None:
    """The scheduler decoded a ``61`` reply (§10 6): motor 1 is at ``pulses``."""
    gateway.state.handle(
        ReplyObserved(loop=SIM_LOOP, time=at, body="1", command=parse("61"), value=pulses)
    )


async def test_seq_wraps_from_255_to_0_with_no_gap(broker: Broker, central: Central) -> None:
    async with edge_node(broker.port) as (gateway, _):
        await central.wait_for("DBIRTH", node="fed", device="gantry")
        for i in range(1, 301):
            mark = central.mark()
            position(gateway, i, i * 0.01)
            await central.wait_for(
                "DDATA", node="fed", since=mark,
                where=lambda m, i=i: m.values.get("Axis/x/Position") == i,
            )  # fmt: skip
        seqs = seqs_in_order(central.of("fed"))
        i = seqs.index(255)
        assert seqs[i + 1] == 0 and len(seqs) > 256


async def test_changes_faster_than_the_broker_are_coalesced_newest_wins(
    broker: Broker, central: Central
) -> None:
    async with edge_node(broker.port) as (gateway, node):
        await central.wait_for("DBIRTH", node="fed", device="gantry")
        mark = central.mark()
        for i in range(1, 1001):  # in one go: the publisher cannot run in between
            position(gateway, i, i * 0.01)
        last = await central.wait_for(
            "DDATA", node="fed", since=mark, where=lambda m: "Axis/x/Position" in m.values
        )
        assert last.values["Axis/x/Position"] == 1000
        assert node.superseded >= 999
        seqs_in_order(central.of("fed"))
