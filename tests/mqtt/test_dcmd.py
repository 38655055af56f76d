"""DCMD stop and acknowledge: off by default; when on, an operator token, audited.

The app and its gateway run in-process on the simulated loop (tests/support/sim_app.py: the real
serial code path through the simulator's pipe); the edge node is wired as ``serve`` wires it
(the API's token book and audit log) and talks to a real mosquitto. What the controller heard
is read from the simulator's line log.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from gateway.mqtt.dcmd import DeviceCommands
from gateway.mqtt.edge_node import EdgeNode
from gateway.service.config import MqttSettings
from tests.mqtt.sparkplug_decoder import command
from tests.support.mqtt_broker import Broker, Central
from tests.support.sim_app import TOKENS, Api, running_app

DCMD = "spBv1.0/plant/DCMD/cmd/gantry"


@asynccontextmanager
async def node_on(api: Api, port: int, *, commands: bool) -> AsyncIterator[EdgeNode]:
    """The app's edge node, connected."""
    settings = MqttSettings(
        host="127.0.0.1", port=port, group="plant", edge_node="cmd", commands=commands
    )
    auth = api.app.state.auth
    handler = DeviceCommands(api.services.axes, auth.book.principal, api.services.audit.record)
    node = EdgeNode(api.runtime, settings, commands=handler)
    task = asyncio.create_task(node.run())
    try:
        await asyncio.wait_for(node.connected.wait(), 20)
        yield node
    finally:
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)
        node.close()


def _dcmd(**metrics: bool | str) -> bytes:
    return command(int(time.time() * 1000), metrics)


def _audited(api: Api) -> list[dict[str, object]]:
    return [e for e in api.services.audit.entries(limit=1000) if e["method"] == "DCMD"]


async def test_dcmd_is_off_by_default(broker: Broker, central: Central) -> None:
    async with running_app(roles=True) as api, node_on(api, broker.port, commands=False):
        birth = await central.wait_for("DBIRTH", node="cmd", device="gantry")
        assert "Axis/x/Stop" not in birth.values and "Command/Token" not in birth.values
        mark = api.mark()
        ask = _dcmd(**{"Command/Token": TOKENS["operator"][0], "Axis/x/Stop": True})
        await central.publish(DCMD, ask)
        # a Rebirth NCMD after it: once its NBIRTH is out, the DCMD was had (or ignored)
        since = central.mark()
        rebirth = command(int(time.time() * 1000), {"Node Control/Rebirth": True})
        await central.publish("spBv1.0/plant/NCMD/cmd", rebirth)
        await central.wait_for("NBIRTH", node="cmd", since=since)
        assert "SS" not in api.heard("1", since=mark)
        assert _audited(api) == []


async def test_dcmd_stop_needs_an_operator_token_and_is_audited(
    broker: Broker, central: Central
) -> None:
    # A move that lasts (60,000 pulses at 5 times real time: some 3 s) to stop on its way.
    async with running_app(roles=True, scale=5.0) as api, node_on(api, broker.port, commands=True):
        birth = await central.wait_for("DBIRTH", node="cmd", device="gantry")
        assert birth.values["Axis/x/Stop"] is False and "Command/Token" in birth.values
        response = await api.client.post(
            "/axes/x/move", json={"position": 60000, "unit": "pulse"}, headers={
                "Authorization": f"Bearer {TOKENS['operator'][0]}"}
        )  # fmt: skip
        assert response.status_code == 202, response.text
        await central.wait_for(
            "DDATA", node="cmd", device="gantry", where=lambda m: m.values.get("Axis/x/Moving")
        )
        mark = api.mark()
        for token in (None, "not-a-token", TOKENS["viewer"][0]):
            metrics: dict[str, bool | str] = {"Axis/x/Stop": True}
            if token is not None:
                metrics["Command/Token"] = token
            await central.publish(DCMD, _dcmd(**metrics))
        other = {"Command/Token": TOKENS["operator"][0], "Axis/x/Target": True}
        await central.publish(DCMD, _dcmd(**other))  # not a command metric: nothing of it
        await central.publish(
            DCMD, _dcmd(**{"Command/Token": TOKENS["operator"][0], "Axis/x/Stop": True})
        )
        stopped = await central.wait_for(
            "DDATA", node="cmd", device="gantry",
            where=lambda m: m.values.get("Axis/x/Moving") is False,
        )  # fmt: skip
        heard = api.heard("1", since=mark)
        assert heard.count("SS") == 1, heard
        assert stopped.values["Axis/x/Moving"] is False
        assert 0 < api.position("1", 1) < 60000  # stopped on its way, in the simulator
        assert all(m.values.get("Axis/x/Position") != 60000 for m in central.of("cmd"))
        entries = _audited(api)
        assert [e["status"] for e in entries] == [401, 401, 403, 422, 200]
        assert entries[-1]["token"] == "operator" and entries[-1]["path"] == DCMD
        assert all("Command/Token" not in str(e["body"]) for e in entries)
        assert all(TOKENS["operator"][0] not in str(e) for e in entries)
