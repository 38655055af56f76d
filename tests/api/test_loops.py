"""GET /loops, /loops/{loop}, the line trace."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from gateway.service.roles import Role
from tests.support.sim_app import Api, auth, running_app


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app() as running:
        await running.identified()
        yield running


async def test_loops_list_and_one(api: Api) -> None:
    r = await api.client.get("/loops")
    assert r.status_code == 200
    [loop] = r.json()
    assert loop["name"] == "sim"
    assert loop["up"] is True and loop["cause"] is None
    assert loop["controllers"] == ["sim.1", "sim.2", "sim.3"]
    assert loop["baud"] == 9600
    assert loop["counters"]["transactions"] > 0  # the poller has been talking
    one = (await api.client.get("/loops/sim")).json()
    assert one["name"] == "sim" and one["controllers"] == loop["controllers"]
    r = await api.client.get("/loops/nowhere")
    assert r.status_code == 404 and "nowhere" in r.json()["detail"]


async def test_the_trace_is_off_until_switched_on(api: Api) -> None:
    r = await api.client.get("/loops/sim/trace")
    assert r.status_code == 200
    assert r.json()["enabled"] is False and r.json()["lines"] == []
    r = await api.client.put("/loops/sim/trace", json={"enabled": False, "controllers": ["2"]})
    assert r.json()["controllers"] == ["sim.2"]
    await api.client.post("/loops/sim/raw", json={"controller": "1", "text": "OH"})
    await api.client.post("/loops/sim/raw", json={"controller": "2", "text": "V"})
    lines = (await api.client.get("/loops/sim/trace")).json()["lines"]
    assert lines and all(line["controller"] == "sim.2" for line in lines)
    sent = [line["text"] for line in lines if line["direction"] == "tx"]
    assert "$2V\\r" in sent
    received = "".join(line["text"] for line in lines if line["direction"] == "rx")
    assert "RC-233 Ver" in received
    r = await api.client.put("/loops/sim/trace", json={"enabled": True, "hex": True, "clear": True})
    assert r.json()["enabled"] is True and r.json()["controllers"] == []
    await api.client.post("/loops/sim/raw", json={"controller": "1", "text": "OH"})
    lines = (await api.client.get("/loops/sim/trace", params={"controller": "1"})).json()["lines"]
    assert "24 31 4f 48 0d" in [line["text"] for line in lines]  # $1OH CR in hex
    r = await api.client.put("/loops/sim/trace", json={"enabled": True, "controllers": ["9"]})
    assert r.status_code == 404


async def test_trace_is_for_admins_and_loops_for_viewers() -> None:
    async with running_app(roles=True) as api:
        viewer = auth(Role.VIEWER)
        assert (await api.client.get("/loops", headers=viewer)).status_code == 200
        assert (await api.client.get("/loops/sim", headers=viewer)).status_code == 200
        op = auth(Role.OPERATOR)
        assert (await api.client.get("/loops/sim/trace", headers=op)).status_code == 403
        r = await api.client.put("/loops/sim/trace", json={"enabled": True}, headers=op)
        assert r.status_code == 403
        assert (await api.client.get("/loops")).status_code == 401
