"""Axis motion through the REST API on the simulated loop: move, home, jog, step, stop.

Positions are checked against the simulator's own counter and the frames against what the
simulated controller heard (its line log). The simulated cell (``serve --simulate``): axis x
is body 1 motor 1, 0.01 mm a pulse, soft limits -40 .. 940 mm; the scene's limit sensors sit
at -5,000 and 95,000 pulses, ORG at 0 .. 499 (gateway/sim/scene.py).
"""

from __future__ import annotations

from tests.support.sim_app import json_of, running_app

MOTION_FRAMES = ("2", "3", "4", "5", "7", "8", "0", "1", "H", "L")


def motion(texts: list[str]) -> list[str]:
    """The frames that move something or set position data (not the poller's reads)."""
    reads = ("", "6", "61", "62", "97", "CL", "CLM1", "CLM2", "90", "96", "GSS", "EP", "94", "V")
    return [t for t in texts if t not in reads and t.startswith(MOTION_FRAMES)]


async def test_move_in_user_units_ends_where_the_simulator_is() -> None:
    async with running_app() as api:
        mark = api.mark()
        r = await api.client.post(
            "/axes/x/move", params={"wait": "true"}, json={"position": 12.5, "unit": "user"}
        )
        assert r.status_code == 200, r.text
        op = json_of(r)
        assert op["state"] == "done"
        assert (op["target"], op["position"], op["position_user"]) == (1250, 1250, 12.5)
        assert api.position("1", 1) == 1250
        # §10 2 then 3: position data, then the absolute move (EP0: no sign).
        assert motion(api.heard("1", mark)) == ["21250", "3"]
        assert op["frames"] == ["$121250", "$13"]
        view = json_of(await api.client.get("/axes/x"))
        assert (view["position"], view["position_user"], view["moving"]) == (1250, 12.5, False)


async def test_relative_move_uses_4_or_5_with_the_distance() -> None:
    async with running_app() as api:
        await api.client.post(
            "/axes/sim.1.1/move?wait=true", json={"position": 1000, "unit": "pulse"}
        )
        mark = api.mark()
        r = await api.client.post(
            "/axes/x/move?wait=true", json={"position": -250, "relative": True, "unit": "pulse"}
        )
        assert json_of(r)["position"] == 750
        assert api.position("1", 1) == 750
        assert motion(api.heard("1", mark)) == ["2250", "5"]  # CCW by 250 (§10 5)
        mark = api.mark()
        r = await api.client.post(
            "/axes/x/move?wait=true", json={"position": 3, "relative": True, "unit": "pulse"}
        )
        assert json_of(r)["position"] == 753
        assert motion(api.heard("1", mark)) == ["23", "4"]  # CW by 3 (§10 4)


async def test_soft_limit_refused_with_field_and_rule_and_nothing_sent() -> None:
    async with running_app() as api:
        mark = api.mark()
        r = await api.client.post("/axes/x/move", json={"position": 950, "unit": "user"})
        assert r.status_code == 422
        problem = json_of(r)
        assert r.headers["content-type"].startswith("application/problem+json")
        assert problem["field"] == "body.position"
        assert "soft limits [-40, 940] mm" in problem["rule"]
        # not a whole number of pulses of 0.01 mm
        r = await api.client.post("/axes/x/move", json={"position": 1.005, "unit": "user"})
        assert r.status_code == 422 and "whole number of pulses" in json_of(r)["rule"]
        # relative: computed from where the axis is (0), 94,001 pulses is past 940 mm
        r = await api.client.post(
            "/axes/x/move", json={"position": 94_001, "relative": True, "unit": "pulse"}
        )
        assert r.status_code == 422 and json_of(r)["field"] == "body.position"
        # negative in unsigned management (EP0, the power-on default): §10 EP, §7-4
        r = await api.client.post("/axes/x/move", json={"position": -10, "unit": "pulse"})
        assert r.status_code == 422 and "EP1" in json_of(r)["rule"]
        # a pulse position must be whole
        r = await api.client.post("/axes/x/move", json={"position": 10.5, "unit": "pulse"})
        assert r.status_code == 422
        assert motion(api.heard("1", mark)) == []
        assert api.position("1", 1) == 0


async def test_signed_management_writes_the_sign() -> None:
    async with running_app() as api:
        r = await api.client.post("/axes/x/move?wait=true", json={"position": 100, "unit": "pulse"})
        assert json_of(r)["state"] == "done"
        # EP1 set behind the gateway's back (another client): the reply teaches the format.
        sched = api.runtime.scheduler("sim")
        from gateway.protocol.command_text import parse

        await sched.submit("1", parse("EP1"))
        mark = api.mark()
        r = await api.client.post("/axes/x/move?wait=true", json={"position": -30, "unit": "pulse"})
        assert json_of(r)["position"] == -30
        assert motion(api.heard("1", mark)) == ["2-30", "3"]


async def test_unknown_axis_and_bad_body() -> None:
    async with running_app() as api:
        r = await api.client.post("/axes/nope/move", json={"position": 1, "unit": "pulse"})
        assert r.status_code == 404
        r = await api.client.post("/axes/x/move", json={"position": 1, "speed": 3, "unit": "pulse"})
        assert r.status_code == 422 and json_of(r)["field"] == "body.speed"
        r = await api.client.post("/axes/x/home", json={"method": "0X"})
        assert r.status_code == 422 and json_of(r)["field"] == "body.method"


async def test_home_from_the_cw_side_ends_at_zero() -> None:
    async with running_app() as api:
        await api.client.post("/axes/x/move?wait=true", json={"position": 2000, "unit": "pulse"})
        mark = api.mark()
        r = await api.client.post("/axes/x/home?wait=true&timeout=30", json={"method": "0"})
        op = json_of(r)
        assert (r.status_code, op["state"], op["position"]) == (200, "done", 0)
        assert api.position("1", 1) == 0
        assert motion(api.heard("1", mark)) == ["0"]


async def test_home_0z_selects_the_motor_first() -> None:
    async with running_app() as api:
        mark = api.mark()
        r = await api.client.post("/axes/y/home", json={"method": "0Z"})
        assert r.status_code == 202, r.text
        heard = api.heard("1", mark)
        # §10 0Z has no motor form: F2 (the scheduler confirms it with reads) then 0Z.
        assert "F2" in heard[: heard.index("0Z")]
        assert motion(heard) == ["0Z"]
        await api.client.post("/axes/y/stop", json={"mode": "immediate"})


async def test_jog_then_stop() -> None:
    async with running_app() as api:
        mark = api.mark()
        # Low speed (OL 500 pps): x has soft limits, so the jog is a move to the soft maximum
        # (94,000) at OL; the scene's CW limit sensor (65,000) lies 130 s of device time away,
        # so the jog is still running when the checks below run, however loaded the host.
        r = await api.client.post("/axes/x/jog", json={"direction": "cw", "speed": "low"})
        assert r.status_code == 202
        op = json_of(r)
        assert r.headers["location"].endswith(f"/operations/{op['id']}")
        await api.until(lambda: api.operations.get(op["id"]).state.value == "moving")
        # the other motor of the controller may not move meanwhile (§2)
        r = await api.client.post("/axes/y/move", json={"position": 10, "unit": "pulse"})
        assert r.status_code == 409 and json_of(r)["field"] == "axis"
        r = await api.client.post("/axes/x/stop", json={"mode": "decelerate"})
        stopped = json_of(r)
        assert (r.status_code, stopped["command"], stopped["operation"]) == (200, "SS", op["id"])
        await api.operations.wait(op["id"], 20)
        ended = json_of(await api.client.get(f"/operations/{op['id']}"))
        assert ended["state"] == "done"  # a jog ends with its stop
        assert ended["position"] == api.position("1", 1) > 0
        # OH lowered to OL for the move to the soft limit, then given back (limit_jog.py)
        assert motion(api.heard("1", mark))[:2] == ["294000", "3"]
        assert "OH500" in api.heard("1", mark) and "7" not in api.heard("1", mark)
        assert "SS" in api.heard("1", mark)
        await api.until(lambda: "OH5000" in api.heard("1", mark))
        assert "21" not in api.heard("1", mark)  # y's move never went out


async def test_jog_to_the_limit_fails_and_errors_can_be_acknowledged() -> None:
    async with running_app() as api:
        # x jogs toward its soft maximum (94,000); the scene's CW limit sensor (65,000) comes
        # first and stops it with a limit error: with wait=true a 409 carrying the operation.
        r = await api.client.post(
            "/axes/x/jog?wait=true&timeout=30", json={"direction": "cw", "speed": "high"}
        )
        assert r.status_code == 409, r.text
        op = r.json()["operation"]
        assert (op["state"], op["error"]["kind"]) == ("failed", "limit_error")
        assert op["position"] == api.position("1", 1) >= 65_000
        view = json_of(await api.client.get("/axes/x"))
        assert view["errors"]["limit"] is True
        r = await api.client.post("/axes/x/errors/ack", json={"kinds": ["limit_error"]})
        assert r.status_code == 200 and json_of(r)["errors"]["limit"] is False


async def test_step_is_one_pulse() -> None:
    async with running_app() as api:
        mark = api.mark()
        r = await api.client.post("/axes/x/step?wait=true", json={"direction": "cw"})
        assert json_of(r)["position"] == 1
        r = await api.client.post("/axes/x/step?wait=true", json={"direction": "cw"})
        assert json_of(r)["position"] == 2 == api.position("1", 1)
        assert motion(api.heard("1", mark)) == ["7*", "7*"]


async def test_fresh_read_and_stop_of_an_idle_axis() -> None:
    async with running_app() as api:
        mark = api.mark()
        r = await api.client.get("/axes/theta", params={"fresh": "true"})
        assert r.status_code == 200 and json_of(r)["position"] == 0
        assert api.heard("2", mark)[-2:] == ["", "62"]
        r = await api.client.post("/axes/theta/stop")  # never refused, even with nothing to stop
        assert (r.status_code, json_of(r)["operation"]) == (200, None)
