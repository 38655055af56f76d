"""The edge node in-process, on a gateway whose loop is not started: a test feeds its cache
the way the loop scheduler does (``StateCache.handle``) and decides what changes."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from gateway.mqtt.edge_node import EdgeNode
from gateway.service.config import MqttSettings
from gateway.service.runtime.runtime import Runtime
from gateway.service.runtime.simulated import SIM_LOOP, simulated_config
from gateway.sim.cli import build_loop
from gateway.sim.serve import SimPort
from gateway.transport.pipe import PipeTransport


@asynccontextmanager
async def edge_node(
    port: int, *, connected: bool = True, **settings: Any
) -> AsyncIterator[tuple[Runtime, EdgeNode]]:
    """A gateway whose loops are not started (the test feeds its cache) and its edge node."""
    sim = build_loop(["1"])
    gateway = Runtime(
        simulated_config(["1"]), transports={SIM_LOOP: PipeTransport(lambda: SimPort(sim))}
    )
    mqtt = MqttSettings(host="127.0.0.1", port=port, group="plant", edge_node="fed", **settings)
    node = EdgeNode(gateway, mqtt)
    gateway.state.set_link(SIM_LOOP, True, 0.0)
    gateway.state.set_online(SIM_LOOP, "1", True, 0.0)
    task = asyncio.create_task(node.run())
    try:
        if connected:
            await asyncio.wait_for(node.connected.wait(), 20)
        yield gateway, node
    finally:
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)
        node.close()
        sim.close()
