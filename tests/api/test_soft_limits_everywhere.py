"""Soft limits on every path that can move an axis: /commands, /raw and jog.

The simulated cell's axes have soft limits at -4,000 and 94,000 pulses (x: -40 .. 940 mm),
inside the scene's limit sensors (-5,000 .. 95,000). Each refusal is a 422 naming the rule,
with nothing of the motion on the wire (the simulator's line log); each accepted motion ends
where the checked target said.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import pytest

from tests.support.sim_app import Api, json_of, running_app

MOVES = ("3", "4", "5", "B", "7", "8", "1")


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app() as running:
        yield running


async def command(api: Api, body: dict[str, Any]) -> Any:
    return await api.client.post("/controllers/sim.1/commands", json=body)


async def raw(api: Api, text: str, motor: int | None = None) -> Any:
    body: dict[str, Any] = {"controller": "1", "text": text}
    if motor is not None:
        body["motor"] = motor
    return await api.client.post("/loops/sim/raw", json=body)


def moved(texts: list[str]) -> list[str]:
    """The motion frames among what a controller heard."""
    return [t for t in texts if t[:1] in MOVES and not t.startswith(("BN",))]


async def arrives(api: Api, axis: str, target: int, reads: int = 500) -> bool:
    """Read the axis now (``fresh``: one line exchange each) until it stands at ``target``;
    a short move can end between two polls, so waiting to see it moving could wait forever."""
    for _ in range(reads):
        view = (await api.client.get(f"/axes/{axis}", params={"fresh": "true"})).json()
        if view["position"] == target and not view["moving"]:
            return True
    return False


async def test_2_then_3_past_the_soft_maximum_is_refused_and_nothing_moves(api: Api) -> None:
    r = await command(api, {"command": "2{pp}", "pp": 99_000})
    assert r.status_code == 200, r.text  # 2 is only data (also the count of 4 and 5)
    mark = api.mark()
    r = await command(api, {"command": "3{mt}", "mt": 1})
    assert r.status_code == 422, r.text
    problem = r.json()
    assert problem["field"] == "command" and "soft limits" in problem["rule"]
    assert "99000" in problem["detail"]
    assert moved(api.heard("1", mark)) == []
    assert api.position("1", 1) == 0
    # Through /raw, the same: field text.
    r = await raw(api, "3", motor=1)
    assert r.status_code == 422 and r.json()["field"] == "text", r.text
    assert moved(api.heard("1", mark)) == []


async def test_3_inside_the_limits_writes_the_checked_data_again_and_moves_there(api: Api) -> None:
    await command(api, {"command": "2{pp}", "pp": 3000})
    mark = api.mark()
    r = await command(api, {"command": "3{mt}", "mt": 1})
    assert r.status_code == 200, r.text
    assert r.json()["frames"] == ["$123000", "$131"]
    assert await arrives(api, "x", 3000)
    assert api.position("1", 1) == 3000
    assert "2D" in api.heard("1", mark)


async def test_relative_4_and_5_are_checked_from_the_known_position(api: Api) -> None:
    await command(api, {"command": "2{pp}", "pp": 95_000})
    mark = api.mark()
    r = await raw(api, "41")  # 0 + 95,000 > 94,000
    assert r.status_code == 422, r.text
    r = await raw(api, "51")  # 0 - 95,000: below the soft minimum (and negative in EP0)
    assert r.status_code == 422, r.text
    assert moved(api.heard("1", mark)) == []
    await command(api, {"command": "2{pp}", "pp": 2000})
    r = await raw(api, "41")
    assert r.status_code == 200, r.text
    assert await arrives(api, "x", 2000)
    assert api.position("1", 1) == 2000


async def test_b_goes_through_the_position_table_entry(api: Api) -> None:
    await api.client.put("/controllers/sim.1/positions/7", json={"position": 99_999})
    mark = api.mark()
    r = await raw(api, "B0071")
    assert r.status_code == 422, r.text
    assert "99999" in r.json()["detail"]
    r = await command(
        api,
        {"command": "B{pn}{dir}", "pn": 7, "dir": "+"},
    )
    assert r.status_code == 422, r.text  # 0 + |99,999| as well
    assert moved(api.heard("1", mark)) == []
    # sequential B: the device's pointer decides the entry: refused, naming the rule
    r = await raw(api, "B1")
    assert r.status_code == 422 and "sequential B" in r.json()["rule"], r.text
    await api.client.put("/controllers/sim.1/positions/7", json={"position": 1500})
    r = await raw(api, "B0071")
    assert r.status_code == 200, r.text
    assert r.json()["frames"] == ["$1A0071500", "$1B0071"]
    assert await arrives(api, "x", 1500)
    assert api.position("1", 1) == 1500


async def test_a_jog_command_on_an_axis_with_soft_limits_is_refused_naming_the_rule(
    api: Api,
) -> None:
    mark = api.mark()
    r = await raw(api, "71")
    assert r.status_code == 422, r.text
    assert "POST /axes/{id}/jog" in r.json()["rule"]
    r = await command(api, {"command": "8{mt}", "mt": 2})
    assert r.status_code == 422, r.text
    assert moved(api.heard("1", mark)) == []


async def test_jog_becomes_a_move_to_the_soft_limit_at_the_jog_speed_ended_by_stop() -> None:
    # High speed: a move at OH to the soft maximum, 94,000 pulses (x: 940 mm).
    async with running_app(scale=5.0) as api:
        mark = api.mark()
        r = await api.client.post("/axes/x/jog", json={"direction": "cw", "speed": "high"})
        assert r.status_code == 202, r.text
        op = json_of(r)
        assert op["kind"] == "jog" and op["target"] == 94_000
        assert op["frames"] == ["$1294000", "$13"]
        await api.until(lambda: api.operations.get(op["id"]).state.value == "moving")
        stop = json_of(await api.client.post("/axes/x/stop"))
        assert stop["operation"] == op["id"]
        done = await api.operations.wait(op["id"], 20)
        assert done.state.value == "done"  # a jog ended by a stop is done
        assert 0 < api.position("1", 1) < 94_000
        assert not any(t in ("7", "71", "8", "81") for t in api.heard("1", mark))


async def test_a_low_speed_jog_runs_to_the_limit_at_ol_and_stops_there() -> None:
    async with running_app() as api:
        # The scene's CW limit sensor is 65,000 pulses from the power-on position: call that
        # position 60,000 (R, §10 R) so the soft maximum (94,000) lies before the sensor, and
        # start at 93,000 so the low-speed run to 94,000 is short.
        r = await raw(api, "R60000", motor=1)
        assert r.status_code == 200, r.text
        first = await api.client.post(
            "/axes/x/move?wait=true", json={"position": 93_000, "unit": "pulse"}
        )
        assert first.status_code == 200, first.text
        mark = api.mark()
        r = await api.client.post("/axes/x/jog?wait=true", json={"direction": "cw"})
        assert r.status_code == 200, r.text
        op = json_of(r)
        assert op["state"] == "done" and op["position"] == 94_000 == api.position("1", 1)
        heard = api.heard("1", mark)
        # OH lowered to OL (500, §16) for the run, and given back afterwards
        assert "OH500" in heard and heard.index("OH500") < heard.index("3")
        await api.until(lambda: "OH5000" in api.heard("1", mark))
        speed = json_of(await api.client.get("/axes/x/speed"))
        assert speed["oh"] == 5000


async def test_a_jog_at_the_soft_limit_is_refused(api: Api) -> None:
    # CCW from 0 in unsigned management (EP0): below 0 positions break (§7-4)
    mark = api.mark()
    r = await api.client.post("/axes/x/jog", json={"direction": "ccw"})
    assert r.status_code == 422, r.text
    assert r.json()["field"] == "body.direction"
    assert moved(api.heard("1", mark)) == []
