"""Stop-all of a controller and of a loop: every axis stopped, never refused to an operator.

The simulated cell (``serve --simulate``): controller 1 (gantry) has x and y, 2 has z and
theta, 3 has gripper and conveyor. Frames are checked against what each simulated controller
heard (its line log); the motions' ends against the operations.
"""

from __future__ import annotations

from gateway.sim.control import Controls
from tests.support.sim_app import auth, json_of, running_app


async def test_a_loop_stop_stops_every_controller_even_leased_ones() -> None:
    async with running_app(roles=True) as api:
        client = api.client
        r = await client.post("/controllers/sim.1/lease", json={"ttl": 60}, headers=auth("alice"))
        assert r.status_code == 200
        jogs = {}
        for axis, body in (("x", "1"), ("z", "2"), ("conveyor", "3")):
            r = await client.post(
                f"/axes/{axis}/jog", json={"direction": "cw"}, headers=auth("alice")
            )
            assert r.status_code == 202, r.text
            jogs[body] = json_of(r)["id"]
        await api.until(lambda: all(api.cached(b).moving for b in ("1", "2", "3")))
        mark = api.mark()
        # bob is an operator without the lease: a stop is never refused to him
        r = await client.post("/loops/sim/stop", headers=auth("bob"))
        assert r.status_code == 200, r.text
        result = json_of(r)
        assert result["loop"] == "sim" and result["outcome"] == "done"
        stops = {s["controller"]: s for s in result["stops"]}
        assert list(stops) == ["sim.1", "sim.2", "sim.3"]
        for body in ("1", "2", "3"):
            stop = stops[f"sim.{body}"]
            assert stop["frames"] == [f"${body}SS"] and stop["outcome"] == "done"
            assert stop["axes"] == [f"sim.{body}.1", f"sim.{body}.2"]
            assert stop["operation"] == jogs[body] and stop["error"] is None
            assert "SS" in api.heard(body, mark)
        for op in jogs.values():
            await api.operations.wait(op, 20)
            ended = await client.get(f"/operations/{op}", headers=auth("viewer"))
            assert json_of(ended)["state"] == "done"


async def test_a_controller_stop_ends_the_motion_of_either_motor() -> None:
    async with running_app(roles=True) as api:
        client = api.client
        # y is motor 2 of controller 1: one S to the controller stops it (§10 F, S)
        r = await client.post("/axes/y/jog", json={"direction": "cw"}, headers=auth("alice"))
        op = json_of(r)["id"]
        await api.until(lambda: api.cached("1").moving)
        mark = api.mark()
        r = await client.post(
            "/controllers/gantry/stop", json={"mode": "immediate"}, headers=auth("bob")
        )
        assert r.status_code == 200, r.text
        stop = json_of(r)
        assert (stop["controller"], stop["command"], stop["frames"]) == ("sim.1", "S", ["$1S"])
        assert (stop["outcome"], stop["operation"]) == ("done", op)
        assert [t for t in api.heard("1", mark) if t in ("S", "SS")] == ["S"]
        await api.operations.wait(op, 20)
        await api.until(lambda: not api.cached("1").moving)


async def test_a_viewer_may_not_stop_and_bad_modes_are_422_with_nothing_sent() -> None:
    async with running_app(roles=True) as api:
        mark = api.mark()
        r = await api.client.post("/loops/sim/stop", headers=auth("viewer"))
        assert r.status_code == 403
        r = await api.client.post(
            "/controllers/sim.1/stop", json={"mode": "gently"}, headers=auth("bob")
        )
        assert r.status_code == 422 and json_of(r)["field"] == "body.mode"
        r = await api.client.post("/loops/nowhere/stop", headers=auth("bob"))
        assert r.status_code == 404
        assert [t for b in ("1", "2", "3") for t in api.heard(b, mark) if t in ("S", "SS")] == []


async def test_a_controller_that_does_not_answer_is_reported_not_left_out() -> None:
    async with running_app() as api:
        Controls(api.sim).power("3", False)
        r = await api.client.post("/loops/sim/stop", json={"mode": "decelerate"})
        assert r.status_code == 200, r.text
        result = json_of(r)
        stops = {s["controller"]: s for s in result["stops"]}
        assert stops["sim.1"]["outcome"] == stops["sim.2"]["outcome"] == "done"
        assert stops["sim.3"]["outcome"] != "done" and stops["sim.3"]["error"]
        assert result["outcome"] != "done"
