"""``seq`` and the bounded queue, on the edge node in-process and a real mosquitto.

The state cache is fed the way the loop scheduler feeds it (``StateCache.handle`` of
``ReplyObserved``, as tests/api/conftest.py does), so the test decides how many changes
happen: 300 positions give 300 DDATA, past 255 -> 0.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from gateway.bus.events import ReplyObserved
from gateway.mqtt.edge_node import EdgeNode
from gateway.protocol.registry import parse
from gateway.service.config import MqttSettings
from gateway.service.gateway import Gateway
from gateway.service.simulated import SIM_LOOP, simulated_config
from gateway.sim.cli import build_loop
from gateway.sim.serve import SimPort
from gateway.transport.pipe import PipeTransport
from tests.mqtt.broker import Broker, Central, seqs_in_order


@asynccontextmanager
async def edge_node(port: int) -> AsyncIterator[tuple[Gateway, EdgeNode]]:
    """A gateway whose loops are not started (the test feeds its cache) and its edge node."""
    sim = build_loop(["1"])
    gateway = Gateway(
        simulated_config(["1"]), transports={SIM_LOOP: PipeTransport(lambda: SimPort(sim))}
    )
    settings = MqttSettings(host="127.0.0.1", port=port, group="plant", edge_node="fed")
    node = EdgeNode(gateway, settings)
    gateway.state.set_link(SIM_LOOP, True, 0.0)
    gateway.state.set_online(SIM_LOOP, "1", True, 0.0)
    task = asyncio.create_task(node.run())
    try:
        await asyncio.wait_for(node.connected.wait(), 20)
        yield gateway, node
    finally:
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)
        node.close()
        sim.close()


def position(gateway: Gateway, pulses: int, at: float) -> None:
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
