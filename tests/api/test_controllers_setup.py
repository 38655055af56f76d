"""Sensor logic (§10 EA), operating mode (§10 E) and EEPROM (§10 AW ... EE///) of a controller."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from gateway.service.roles import Role
from tests.support.sim_app import Api, auth, running_app

CTL = "/controllers/sim.1"


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app() as running:
        await running.identified()
        yield running


async def test_sensor_logic_per_motor(api: Api) -> None:
    r = await api.client.put(f"{CTL}/sensor-logic/2", json={"org": "B", "inp": "B"})
    assert r.status_code == 200, r.text
    assert r.json()["frames"] == ["$1EA28"]  # bit 3 ORG, bit 5 INP (§10 EA) = 0x28
    two = (await api.client.get(f"{CTL}/sensor-logic/2")).json()
    assert two["org"] == "B" and two["inp"] == "B" and two["limit"] == "A"
    one = (await api.client.get(f"{CTL}/sensor-logic/1")).json()
    assert one["org"] == "A"
    assert "F2" in api.heard()  # the motor is selected before EA
    r = await api.client.put(f"{CTL}/sensor-logic/3", json={})
    assert r.status_code == 422 and r.json()["field"] == "path.motor"
    r = await api.client.put(f"{CTL}/sensor-logic/1", json={"org": "C"})
    assert r.status_code == 422 and r.json()["field"] == "body.org"


async def test_mode_read_and_set(api: Api) -> None:
    assert (await api.client.get(f"{CTL}/mode")).json() == {"controller": "sim.1", "mode": 0}
    r = await api.client.put(f"{CTL}/mode", json={"mode": 1})
    assert r.status_code == 200 and r.json()["frames"] == ["$1E1"]
    assert (await api.client.get(f"{CTL}/mode")).json()["mode"] == 1
    r = await api.client.put(f"{CTL}/mode", json={"mode": 3})
    assert r.status_code == 422 and r.json()["field"] == "body.mode"


async def test_mode_and_sensor_logic_refused_while_moving(api: Api) -> None:
    # A move of 60,000 pulses (12 s at OH): 7/8 are refused on axes with soft limits
    r = await api.client.post(f"{CTL}/commands", json={"command": "2{pp}", "pp": 60_000})
    assert r.status_code == 200
    r = await api.client.post(f"{CTL}/commands", json={"command": "3{mt}", "mt": 2})
    assert r.status_code == 200, r.text
    await api.until(lambda: api.cached().moving)
    mark = api.mark()
    r = await api.client.put(f"{CTL}/mode", json={"mode": 1})
    assert r.status_code == 409 and "§10 E" in r.json()["detail"]
    r = await api.client.put(f"{CTL}/sensor-logic/2", json={"org": "B"})
    assert r.status_code == 409 and "§10 EA" in r.json()["detail"]
    heard = api.heard(since=mark)
    assert "E1" not in heard and "EA08" not in heard
    await api.client.post(f"{CTL}/commands", json={"command": "S"})
    await api.until(lambda: not api.cached().moving)


@pytest.mark.parametrize(
    ("action", "area", "text"),
    [
        ("save", "settings", "DW"),
        ("save", "positions", "AW"),
        ("save", "program", "IW"),
        ("load", "settings", "DL"),
        ("load", "positions", "AL"),
        ("load", "program", "IL"),
    ],
)
async def test_eeprom_save_and_load(api: Api, action: str, area: str, text: str) -> None:
    r = await api.client.post(f"{CTL}/eeprom/{action}", json={"area": area})
    assert r.status_code == 200, r.text
    assert r.json()["frames"] == [f"$1{text}"] and r.json()["outcome"] == "done"


async def test_eeprom_round_trip_of_the_position_table(api: Api) -> None:
    await api.client.put(f"{CTL}/positions/3", json={"position": 777})
    await api.client.post(f"{CTL}/eeprom/save", json={"area": "positions"})
    await api.client.put(f"{CTL}/positions/3", json={"position": 1})
    await api.client.post(f"{CTL}/eeprom/load", json={"area": "positions"})
    assert (await api.client.get(f"{CTL}/positions/3")).json()["position"] == 777
    r = await api.client.post(f"{CTL}/eeprom/erase")
    assert r.status_code == 200 and r.json()["frames"] == ["$1EE///"]
    assert r.json()["outcome"] == "done"  # the $1* after the erase came (§10 EE///)
    r = await api.client.post(f"{CTL}/eeprom/save", json={"area": "everything"})
    assert r.status_code == 422 and r.json()["field"] == "body.area"


async def test_mode_and_eeprom_are_for_admins() -> None:
    async with running_app(roles=True) as api:
        op = auth(Role.OPERATOR)
        mark = api.mark()
        assert (
            await api.client.put(f"{CTL}/mode", json={"mode": 1}, headers=op)
        ).status_code == 403
        for action in ("save", "load"):
            r = await api.client.post(
                f"{CTL}/eeprom/{action}", json={"area": "settings"}, headers=op
            )
            assert r.status_code == 403
        assert (await api.client.post(f"{CTL}/eeprom/erase", headers=op)).status_code == 403
        heard = api.heard(since=mark)
        assert not {"E1", "DW", "DL", "EE///"} & set(heard)
        assert (await api.client.get(f"{CTL}/mode", headers=op)).status_code == 200
        r = await api.client.put(f"{CTL}/sensor-logic/1", json={}, headers=op)
        assert r.status_code == 200
