"""Local and remote control through the simulated line: an admin or a key switch locks out
motion and settings from the network; stops still go out; views, the feed and the audit log
show every change."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator

import pytest

from gateway.service.config import GatewayConfig, parse_config
from gateway.service.control import ControlChange
from gateway.service.runtime.simulated import simulated_config
from gateway.sim.control import Controls
from tests.support.sim_app import WAIT, Api, auth, json_of, running_app
from tests.support.ws_server import check_server_message

KEY_BIT = 3  # the key switch of controller 1: general input bit 3 (§10 C), ON = local


def _config_with_key_switch() -> GatewayConfig:
    data = simulated_config(("1", "2")).model_dump(mode="json", exclude_none=True)
    data["loops"][0]["controllers"][0]["local_input"] = {"bit": KEY_BIT, "active": "on"}
    return parse_config(data)


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app(("1", "2"), roles=True) as api:
        yield api


def _moves(heard: list[str]) -> list[str]:
    """Position data and moves (§10 2, 3, 4, 5) among the frames heard."""
    return [t for t in heard if t[:1] in ("2", "3", "4", "5") and not t.startswith("6")]


async def _changes(api: Api) -> asyncio.Queue[ControlChange]:
    queue: asyncio.Queue[ControlChange] = asyncio.Queue()
    api.runtime.control.changes.subscribe(queue.put_nowait)
    return queue


async def test_admin_local_refuses_motion_and_settings_and_lets_stops_out(api: Api) -> None:
    feed = api.services.feed
    reader = feed.open(backlog=10_000)
    reader.subscribe(["controller:sim.1", "axis:x", "event:control"])
    assert json.loads(await reader.get())["type"] == "snapshot"

    r = await api.client.put(
        "/controllers/sim.1/control", json={"state": "local"}, headers=auth("admin")
    )
    assert r.status_code == 200, r.text
    body = json_of(r)
    assert body["state"] == "local"
    assert body["sources"][0]["kind"] == "controller" and body["sources"][0]["by"] == "admin"

    mark = api.mark()
    r = await api.client.post(
        "/axes/x/move", json={"position": 10, "unit": "user"}, headers=auth("operator")
    )
    assert r.status_code == 409, r.text
    problem = json_of(r)
    assert "local control" in problem["detail"] and "admin" in problem["detail"]
    assert problem["field"] == "control"
    for path, payload in (
        ("/axes/x/home", {"method": "0"}),
        ("/axes/x/jog", {"direction": "cw", "speed": "low"}),
        ("/axes/x/step", {"direction": "cw"}),
        ("/axes/x/speed", {"oh": 600}),
    ):
        method = api.client.put if path.endswith("speed") else api.client.post
        r = await method(path, json=payload, headers=auth("operator"))
        assert r.status_code == 409, (path, r.text)
        assert "local control" in json_of(r)["detail"], path
    r = await api.client.post(
        "/controllers/sim.1/commands",
        json={"command": "OH{hs}", "hs": 4000},
        headers=auth("operator"),
    )
    assert r.status_code == 409, r.text
    assert "'OH4000'" in json_of(r)["detail"]
    r = await api.client.post(
        "/loops/sim/raw", json={"controller": "1", "text": "OH500"}, headers=auth("admin")
    )
    assert r.status_code == 409, r.text
    assert "local control" in json_of(r)["detail"]
    r = await api.client.post("/controllers/sim.1/program/run", json={}, headers=auth("admin"))
    assert r.status_code == 409, r.text
    # Reads still answer; the other controller of the loop is not affected.
    r = await api.client.post(
        "/loops/sim/raw", json={"controller": "1", "text": "OH"}, headers=auth("admin")
    )
    assert r.status_code == 200, r.text
    assert not _moves(api.heard("1", mark))
    assert not any(t.startswith("OH5") for t in api.heard("1", mark))

    r = await api.client.post("/axes/x/stop", json={"mode": "decelerate"}, headers=auth("operator"))
    assert r.status_code == 200, r.text
    assert "SS" in api.heard("1", mark)
    r = await api.client.post("/controllers/sim.1/stop", headers=auth("operator"))
    assert r.status_code == 200, r.text

    views = json_of(await api.client.get("/controllers/sim.1", headers=auth("viewer")))
    assert views["control"]["state"] == "local"
    axis = json_of(await api.client.get("/axes/x", headers=auth("viewer")))
    assert axis["control"]["state"] == "local"
    other = json_of(await api.client.get("/axes/y", headers=auth("viewer")))
    assert other["control"]["state"] == "local"  # y is motor 2 of the same controller

    r = await api.client.put(
        "/controllers/sim.1/control", json={"state": "remote"}, headers=auth("admin")
    )
    assert r.status_code == 200 and json_of(r)["state"] == "remote", r.text
    mark = api.mark()
    r = await api.client.post(
        "/axes/x/move?wait=true", json={"position": 10, "unit": "user"}, headers=auth("operator")
    )
    assert r.status_code == 200, r.text
    assert "3" in api.heard("1", mark)

    # The feed: for each change, the views with the new state (seq numbered), then the event.
    messages = []
    while reader.pending:
        messages.append(check_server_message(await reader.get()))
    control_changes = [m for m in messages if m["type"] == "change" and "control" in m["changed"]]
    states = [(m["topic"], m["data"]["control"]["state"]) for m in control_changes]
    assert ("controller:sim.1", "local") in states and ("axis:sim.1.1", "local") in states
    assert ("controller:sim.1", "remote") in states and ("axis:sim.1.1", "remote") in states
    events = [m for m in messages if m["type"] == "event" and m["kind"] == "control"]
    assert [e["data"]["state"] for e in events] == ["local", "remote"]
    assert events[0]["data"]["cause"] == "local set by admin on controller sim.1"
    seqs = [m["seq"] for m in messages]
    assert seqs == sorted(seqs)
    reader.close()

    audit = json_of(await api.client.get("/audit?limit=200", headers=auth("admin")))
    puts = [
        e
        for e in audit["entries"]
        if e["path"].endswith("/controllers/sim.1/control") and e.get("event") != "intent"
    ]
    assert [(e["token"], e["status"], e["result"]) for e in puts] == [
        ("admin", 200, "local"),
        ("admin", 200, "remote"),
    ]


async def test_a_loop_set_local_refuses_every_controller_on_it(api: Api) -> None:
    r = await api.client.put("/loops/sim/control", json={"state": "local"}, headers=auth("admin"))
    assert r.status_code == 200, r.text
    body = json_of(r)
    assert body["local"]["by"] == "admin"
    assert {c["controller"]: c["state"] for c in body["controllers"]} == {
        "sim.1": "local",
        "sim.2": "local",
    }
    mark = api.mark()
    for axis in ("x", "z"):
        r = await api.client.post(
            f"/axes/{axis}/move", json={"position": 1, "unit": "user"}, headers=auth("operator")
        )
        assert r.status_code == 409, r.text
        assert "on its loop" in json_of(r)["detail"]
    assert not _moves(api.heard("1", mark)) and not _moves(api.heard("2", mark))
    r = await api.client.post("/loops/sim/stop", headers=auth("operator"))
    assert r.status_code == 200, r.text
    assert "SS" in api.heard("1", mark) or "S" in api.heard("1", mark)

    # A controller set local on its own stays local when the loop goes remote.
    await api.client.put(
        "/controllers/sim.2/control", json={"state": "local"}, headers=auth("admin")
    )
    r = await api.client.put("/loops/sim/control", json={"state": "remote"}, headers=auth("admin"))
    states = {c["controller"]: c["state"] for c in json_of(r)["controllers"]}
    assert states == {"sim.1": "remote", "sim.2": "local"}
    r = await api.client.post(
        "/axes/x/move?wait=true", json={"position": 1, "unit": "user"}, headers=auth("operator")
    )
    assert r.status_code == 200, r.text


async def test_viewer_and_operator_may_not_change_the_state(api: Api) -> None:
    for who in ("viewer", "operator"):
        for path in ("/controllers/sim.1/control", "/loops/sim/control"):
            r = await api.client.put(path, json={"state": "local"}, headers=auth(who))
            assert r.status_code == 403, (who, path, r.text)
    r = await api.client.put(
        "/controllers/sim.1/control", json={"state": "off"}, headers=auth("admin")
    )
    assert r.status_code == 422, r.text
    assert "state" in json.dumps(json_of(r))
    view = json_of(await api.client.get("/controllers/sim.1", headers=auth("viewer")))
    assert view["control"] == {"state": "remote", "sources": [], "key_switch": None}


async def test_the_key_switch_input_puts_the_controller_in_local() -> None:
    async with running_app(("1", "2"), roles=True, config=_config_with_key_switch()) as api:
        changes = await _changes(api)
        ctl = api.runtime.topology.controller("sim.1")
        # Read once by now, or soon: the switch is off, so the controller ends remote.
        while api.runtime.control.state(ctl).value != "remote":
            await asyncio.wait_for(changes.get(), WAIT)
        view = json_of(await api.client.get("/controllers/sim.1", headers=auth("viewer")))
        assert view["control"]["key_switch"]["bit"] == KEY_BIT
        assert view["control"]["key_switch"]["input_on"] is False

        mark = api.mark()
        Controls(api.sim).input("1", KEY_BIT, True)
        change = await asyncio.wait_for(changes.get(), WAIT)
        assert change.view.state.value == "local" and change.source == "key_switch"
        # Within a poll period: the change came with the first C read after the switch (or
        # the one already in flight when it turned).
        assert 1 <= api.heard("1", mark).count("C") <= 2

        mark = api.mark()
        r = await api.client.post(
            "/axes/x/move", json={"position": 5, "unit": "user"}, headers=auth("operator")
        )
        assert r.status_code == 409, r.text
        assert f"key switch: input bit {KEY_BIT} on" in json_of(r)["detail"]
        # An admin cannot lift a key switch: the answer says what still holds it.
        r = await api.client.put(
            "/controllers/sim.1/control", json={"state": "remote"}, headers=auth("admin")
        )
        assert json_of(r)["state"] == "local"
        assert json_of(r)["sources"][0]["kind"] == "key_switch"
        r = await api.client.post("/axes/x/stop", headers=auth("operator"))
        assert r.status_code == 200, r.text
        assert not _moves(api.heard("1", mark)) and "SS" in api.heard("1", mark)

        Controls(api.sim).input("1", KEY_BIT, False)
        change = await asyncio.wait_for(changes.get(), WAIT)
        assert change.view.state.value == "remote"
        mark = api.mark()
        r = await api.client.post(
            "/axes/x/move?wait=true", json={"position": 5, "unit": "user"}, headers=auth("operator")
        )
        assert r.status_code == 200, r.text
        assert "3" in api.heard("1", mark)

        audit = json_of(await api.client.get("/audit?limit=500", headers=auth("admin")))
        inputs = [e for e in audit["entries"] if e["method"] == "INPUT"]
        assert [(e["result"], e["cause"]) for e in inputs][-2:] == [
            ("local", f"key switch: input bit {KEY_BIT} on"),
            ("remote", f"key switch: input bit {KEY_BIT} off"),
        ]
