"""The origin of an axis: homed by an origin search, lost by a controller reset.

Through the gateway's real serial path to the simulator (in-process pipe). The power cycle is
the simulator's control surface (``Controls.power_cycle``): RAM lost, both counters at 0
where the axes stand (§16). x has soft limits -40 .. 940 mm (0.01 mm a pulse).
"""

from __future__ import annotations

import asyncio
import json
import logging
from typing import Any

import pytest

from gateway.bus.state_types import Origin
from gateway.service.events import EventKind
from gateway.sim.control import Controls
from tests.support.sim_app import Api, json_of, running_app

MOVES = ("0", "1", "3", "4", "5", "7", "8", "B")


def moved(texts: list[str]) -> list[str]:
    """The motion frames among what a controller heard."""
    return [t for t in texts if t[:1] in MOVES and not t.startswith("BN")]


async def home(api: Api, axis: str = "x") -> None:
    r = await api.client.post(f"/axes/{axis}/home?wait=true&timeout=30", json={"method": "0"})
    assert (r.status_code, json_of(r)["state"]) == (200, "done"), r.text


async def move(api: Api, axis: str, position: float, unit: str, relative: bool = False) -> object:
    body = {"position": position, "unit": unit, "relative": relative}
    return await api.client.post(f"/axes/{axis}/move?wait=true&timeout=30", json=body)


async def test_a_power_cycle_loses_the_origin_and_moves_that_need_it_wait_for_a_home(
    caplog: pytest.LogCaptureFixture,
) -> None:
    async with running_app(("1",)) as api:
        view = json_of(await api.client.get("/axes/x"))
        assert (view["homed"], view["origin"]) == (False, "unknown")  # nothing seen yet
        r = await move(api, "x", 2000, "pulse")
        assert r.status_code == 200, r.text  # type: ignore[attr-defined]
        await home(api)
        view = json_of(await api.client.get("/axes/x"))
        assert (view["homed"], view["origin"]) == (True, "homed")
        r = await move(api, "x", 100, "user")
        assert r.status_code == 200, r.text  # type: ignore[attr-defined]
        assert api.position("1", 1) == 10_000

        caplog.set_level(logging.INFO, logger="gateway.origin")
        Controls(api.sim).power_cycle("1")  # the counters restart at 0 where the axes stand
        mark = api.mark()
        # An absolute move in user units: 150 mm would be 250 mm from the real origin.
        r = await move(api, "x", 150, "user")
        assert r.status_code == 409, r.text  # type: ignore[attr-defined]
        problem = r.json()  # type: ignore[attr-defined]
        assert "home first" in problem["rule"] and problem["field"] == "axis"
        # A relative move on an axis with soft limits: refused too, not checked against 100 mm.
        r = await move(api, "x", -60, "user", relative=True)
        assert r.status_code == 409 and "home first" in r.json()["rule"]  # type: ignore[attr-defined]
        r = await api.client.post("/axes/y/move", json={"position": 10, "unit": "pulse"})
        assert r.status_code == 409, r.text  # both counters restarted: y too
        assert moved(api.heard("1", mark)) == []
        assert api.position("1", 1) == 0

        for axis in ("x", "y"):
            view = json_of(await api.client.get(f"/axes/{axis}"))
            assert (view["homed"], view["origin"]) == (False, "lost"), view
            assert view["position_user"] is None  # mm from an origin that is gone: unknown
        events = [e for e in api.events if e.kind is EventKind.ORIGIN]
        assert [e.data["origin"] for e in events if e.data["axis"] == "sim.1.1"] == [
            "homed",
            "lost",
        ]
        assert any("origin lost" in r.getMessage() for r in caplog.records)
        entries = json_of(await api.client.get("/audit", params={"limit": 500}))["entries"]
        lost = [e for e in entries if e.get("event") == "origin_lost"]
        assert {e["path"] for e in lost} == {"/api/v1/axes/sim.1.1", "/api/v1/axes/sim.1.2"}

        # Stops pass; homing passes and gives the origin back.
        r = await api.client.post("/axes/x/stop", json={"mode": "immediate"})
        assert r.status_code == 200, r.text
        r = await move(api, "x", 2000, "pulse")  # x has soft limits: still refused
        assert r.status_code == 409  # type: ignore[attr-defined]
        await home(api)
        assert json_of(await api.client.get("/axes/x"))["homed"] is True
        r = await move(api, "x", 150, "user")
        assert r.status_code == 200, r.text  # type: ignore[attr-defined]
        assert api.position("1", 1) == 15_000


async def test_commands_that_move_a_soft_limited_axis_wait_for_a_home_after_a_reset() -> None:
    async with running_app(("1",)) as api:
        r = await move(api, "x", 3000, "pulse")
        assert r.status_code == 200  # type: ignore[attr-defined]
        Controls(api.sim).power_cycle("1")
        mark = api.mark()
        body = {"command": "1{mt}", "mt": 1}  # to the electrical origin: a reset moved it
        r = await api.client.post("/controllers/sim.1/commands", json=body)
        assert r.status_code == 409 and "home first" in r.json()["rule"], r.text
        one_pulse = {"controller": "1", "text": "7*", "motor": 1}
        r = await api.client.post("/loops/sim/raw", json=one_pulse)
        assert r.status_code == 409, r.text
        assert moved(api.heard("1", mark)) == []
        # An origin search is what gives it back: it passes.
        r = await api.client.post("/controllers/sim.1/commands", json={"command": "0"})
        assert r.status_code == 200, r.text


async def test_the_first_reading_after_a_reset_is_not_checked_against_the_old_position() -> None:
    """A relative move right after the cycle on an axis without soft limits, in pulses: the
    target is the new counter plus the distance, never the stale position plus it."""
    async with running_app(("3",)) as api:
        r = await move(api, "gripper", 5000, "pulse")
        assert r.status_code == 200  # type: ignore[attr-defined]
        Controls(api.sim).power_cycle("3")
        r = await move(api, "gripper", 100, "pulse", relative=True)
        # The gripper has soft limits in the simulated cell too: refused until homed.
        assert r.status_code == 409, r.text  # type: ignore[attr-defined]
        view = json_of(await api.client.get("/axes/gripper"))
        assert (view["origin"], view["position"], view["counter"]) == ("lost", 0, 0)


async def test_the_feed_publishes_homed_in_the_axis_change_and_an_origin_event() -> None:
    async with running_app(("1",)) as api:
        feed = api.services.feed
        client = feed.open(backlog=100_000)
        client.subscribe(["axis:x", "event:origin"])
        snapshot = json.loads(await client.get())
        assert snapshot["type"] == "snapshot"
        assert snapshot["axes"][0]["homed"] is False
        r = await move(api, "x", 3000, "pulse")
        assert r.status_code == 200  # type: ignore[attr-defined]
        Controls(api.sim).power_cycle("1")
        r = await move(api, "x", 10, "user")
        assert r.status_code == 409  # type: ignore[attr-defined]

        async def until_lost() -> tuple[dict[str, Any], dict[str, Any]]:
            change: dict[str, Any] | None = None
            while True:
                message = json.loads(await client.get())
                if message["type"] == "change" and "origin" in message["changed"]:
                    change = message
                elif message["type"] == "event" and message["kind"] == "origin":
                    assert change is not None  # the view changes first, then the event
                    return change, message

        change, event = await asyncio.wait_for(until_lost(), 20)
        assert "homed" in change["changed"] or change["data"]["homed"] is False
        assert (change["data"]["origin"], change["data"]["homed"]) == ("lost", False)
        assert event["resource"] == "axis:sim.1.1"
        assert event["data"]["origin"] == "lost" and "reset" in event["data"]["cause"]


async def test_an_idle_controller_reset_is_seen_without_any_request() -> None:
    async with running_app(("1",)) as api:
        r = await move(api, "x", 3000, "pulse")
        assert r.status_code == 200  # type: ignore[attr-defined]
        events = len(api.events)
        Controls(api.sim).power_cycle("1")
        # The poller's next reading of 0 is read again at once, and the reset is seen.
        await api.until(lambda: api.runtime.state.axis("sim", "1", 1).origin.value == "lost")
        assert any(e.kind is EventKind.ORIGIN for e in api.events[events:])


async def test_a_controller_reset_makes_the_selection_unknown_so_motor_2_is_selected_again() -> (
    None
):
    """After a power cycle the controller selects a motor of its own (§16): a setting of motor
    2 must go out with ``F2`` before it, never on the gateway's selection from before."""
    async with running_app(("1",)) as api:
        await api.identified()
        r = await move(api, "sim.1.2", 3000, "pulse")
        assert r.status_code == 200, r.text  # type: ignore[attr-defined]
        r = await api.client.post(
            "/controllers/sim.1/commands", params={"motor": 2}, json={"command": "OH"}
        )
        assert r.status_code == 200, r.text
        assert api.runtime.state.controller("sim", "1").selection_confirmed  # motor 2, known
        Controls(api.sim).power_cycle("1")
        await api.until(lambda: api.runtime.state.axis("sim", "1", 2).origin == Origin.LOST)
        mark = api.mark()
        r = await api.client.post(
            "/controllers/sim.1/commands", params={"motor": 2}, json={"command": "OH"}
        )
        assert r.status_code == 200, r.text
        heard = api.heard("1", mark)
        assert "F2" in heard and heard.index("F2") < heard.index("OH"), heard


async def test_a_preset_from_outside_the_gateway_to_zero_loses_the_origin() -> None:
    """The control surface's ``preset``: an ``R`` the gateway did not send. Its counter now
    says 0 where the axis stood at 3000: the gateway cannot tell it from a reset, and says the
    origin is lost rather than trusting the old one."""
    async with running_app(("1",)) as api:
        r = await move(api, "x", 3000, "pulse")
        assert r.status_code == 200, r.text  # type: ignore[attr-defined]
        Controls(api.sim).preset("1", 1, 0)
        await api.until(lambda: api.runtime.state.axis("sim", "1", 1).origin == Origin.LOST)
        view = json_of(await api.client.get("/axes/x"))
        assert (view["origin"], view["position"], view["counter"]) == ("lost", 0, 0)
        # the view keeps why, for a client that was not listening when it happened
        assert "reads 0 after 3000" in view["origin_cause"], view
        await home(api)
        assert json_of(await api.client.get("/axes/x"))["origin_cause"] is None
