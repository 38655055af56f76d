"""GET/PUT /controllers/{id}/positions/{n}: the position table (§10 A)."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from gateway.service.roles import Role
from tests.support.sim_app import Api, auth, running_app

URL = "/controllers/sim.1/positions"


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app() as running:
        await running.identified()
        yield running


async def test_write_then_read_an_entry(api: Api) -> None:
    mark = api.mark()
    r = await api.client.put(f"{URL}/5", json={"position": 1000})
    assert r.status_code == 200, r.text
    assert r.json()["frames"] == ["$1A0051000"]  # pn exactly 3 digits (§10 A)
    assert "A0051000" in api.heard(since=mark)
    assert api.device().table[5] == 1000
    r = await api.client.get(f"{URL}/5")
    assert r.json() == {"controller": "sim.1", "number": 5, "position": 1000, "unit": "pulse"}
    assert "A005D" in api.heard(since=mark)
    assert (await api.client.get(f"{URL}/999")).json()["position"] == 0  # §16: all 0


async def test_signed_positions_carry_a_sign(api: Api) -> None:
    cmd = "/controllers/sim.1/commands"
    assert (await api.client.post(cmd, json={"command": "EP1"})).status_code == 200
    mark = api.mark()
    r = await api.client.put(f"{URL}/7", json={"position": -1000})
    assert r.status_code == 200, r.text
    assert "A007-1000" in api.heard(since=mark)
    assert (await api.client.get(f"{URL}/7")).json()["position"] == -1000
    # Mode 1 is always signed management (§10 EP): positive values get a '+' too.
    assert (await api.client.post(cmd, json={"command": "E{mode}", "mode": 1})).status_code == 200
    await api.client.get("/controllers/sim.1", params={"fresh": "true"})
    r = await api.client.put(f"{URL}/8", json={"position": 1000})
    assert r.status_code == 200 and r.json()["frames"] == ["$1A008+1000"]
    r = await api.client.put(f"{URL}/8", json={"position": 9_000_000})
    assert r.status_code == 422 and r.json()["field"] == "body.position"
    assert "-8388608..8388607" in r.json()["rule"]  # the signed range (§10 EP)


async def test_store_the_current_position(api: Api) -> None:
    cmd = "/controllers/sim.1/commands"
    r = await api.client.post(cmd, json={"command": "R{pp}", "pp": 1234}, params={"motor": 2})
    assert r.status_code == 200, r.text
    r = await api.client.put(f"{URL}/12", json={"current": True, "motor": 2})
    assert r.status_code == 200 and r.json()["frames"] == ["$1A012"]
    assert (await api.client.get(f"{URL}/12")).json()["position"] == 1234


@pytest.mark.parametrize(
    ("n", "body", "field"),
    [
        (1000, {"position": 1}, "path.n"),
        (-1, {"position": 1}, "path.n"),
        (1, {"position": 16_777_216}, "body.position"),
        (1, {"position": 1, "current": True}, "body"),
        (1, {}, "body"),
        (1, {"position": "x"}, "body.position"),
        (1, {"position": 1, "extra": 2}, "body.extra"),
    ],
)
async def test_bad_requests_name_the_field(api: Api, n: int, body: dict, field: str) -> None:
    mark = api.mark()
    r = await api.client.put(f"{URL}/{n}", json=body)
    assert r.status_code == 422, r.text
    assert r.json()["field"] == field
    assert not [t for t in api.heard(since=mark) if t.startswith("A")]


async def test_unknown_controller_lease_and_roles() -> None:
    async with running_app(roles=True) as api:
        op = auth(Role.OPERATOR)
        r = await api.client.get("/controllers/sim.8/positions/1", headers=op)
        assert r.status_code == 404
        r = await api.client.put(f"{URL}/1", json={"position": 5}, headers=auth(Role.VIEWER))
        assert r.status_code == 403
        api.leases.acquire("sim.1.1", "admin", 60)  # the admin token holds axis 1
        mark = api.mark()
        r = await api.client.put(f"{URL}/1", json={"position": 5}, headers=op)
        assert r.status_code == 409 and r.json()["holder"] == "admin"
        assert "A0015" not in api.heard(since=mark)
        r = await api.client.put(f"{URL}/1", json={"position": 5}, headers=auth(Role.ADMIN))
        assert r.status_code == 200
