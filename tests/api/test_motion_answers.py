"""What a motion request answers: status codes a client can trust, explicit units, and a
conflict with a motion answered as a conflict (409), never as a device fault (504).

* ``?wait=true`` answers 2xx only for ``done``; ``failed`` is a 409 problem and ``unknown`` a
  504 problem, both carrying the operation (gateway/api/motion_problems.py).
* ``unit`` is required on a move; every position field of a view says its unit.
* The per-motor speed data of motor 2 cannot be read while motor 1 moves (``F`` is refused
  then, §10 F): 409, before anything is sent.
"""

from __future__ import annotations

import asyncio

from gateway.sim.control import Controls
from tests.support.sim_app import json_of, running_app


async def test_a_move_stopped_by_ems_with_wait_is_a_409_problem_carrying_the_operation() -> None:
    # Time scale 5: the 18 s move lasts 3.6 s here, so EMS lands in it on a loaded host.
    async with running_app(scale=5.0) as api:
        waiting = asyncio.ensure_future(
            api.client.post("/axes/x/move?wait=true", json={"position": 90_000, "unit": "pulse"})
        )
        await api.until(lambda: api.cached("1").moving)
        Controls(api.sim).ems("1", True)
        r = await asyncio.wait_for(waiting, 20)
        assert r.status_code == 409, r.text  # was 200 with state failed
        problem = r.json()
        assert problem["type"] == "urn:rc233-gateway:problem:motion-failed"
        op = problem["operation"]
        assert op["state"] == "failed" and op["error"]["kind"] == "emergency_stop"
        assert op["position"] == api.position("1", 1) < 90_000
        assert r.headers["location"] == f"/api/v1/operations/{op['id']}"


async def test_with_wait_only_done_is_2xx_failed_is_409_with_the_operation() -> None:
    async with running_app() as api:
        # The CW limit sensor turned ON stops a CW move with a limit error (§10 "" bit 1).
        Controls(api.sim).sensor("1", 1, "cw_limit", True)
        r = await api.client.post(
            "/axes/x/move?wait=true", json={"position": 1000, "unit": "pulse"}
        )
        assert r.status_code == 409, r.text
        assert r.headers["content-type"].startswith("application/problem+json")
        problem = r.json()
        assert problem["type"] == "urn:rc233-gateway:problem:motion-failed"
        op = problem["operation"]
        assert op["state"] == "failed" and op["error"]["kind"] == "limit_error"
        assert r.headers["location"].endswith(op["id"])
        assert op["id"] in problem["detail"]
        # A move that ends done is still 200.
        Controls(api.sim).sensor("1", 1, "cw_limit", None)
        await api.client.post("/axes/x/errors/ack")
        ok = await api.client.post(
            "/axes/x/move?wait=true", json={"position": 500, "unit": "pulse"}
        )
        assert ok.status_code == 200, ok.text
        assert json_of(ok)["state"] == "done"


async def test_a_move_without_unit_is_refused_and_nothing_is_sent() -> None:
    async with running_app() as api:
        mark = api.mark()
        r = await api.client.post("/axes/x/move", json={"position": 10})
        assert r.status_code == 422, r.text
        assert r.json()["field"] == "body.unit"
        assert not any(t.startswith(("2", "3", "4", "5")) for t in api.heard("1", mark))
        assert api.operations.list() == []
        # The same with the unit said: 10 mm on x (0.01 mm a pulse) is 1,000 pulses.
        r = await api.client.post("/axes/x/move?wait=true", json={"position": 10, "unit": "user"})
        assert r.status_code == 200, r.text
        assert json_of(r)["target"] == 1000 == api.position("1", 1)


async def test_every_position_of_a_view_says_its_unit() -> None:
    async with running_app() as api:
        axis = json_of(await api.client.get("/axes/x"))
        assert axis["units"] == {
            "position": "pulse",
            "counter": "pulse",
            "position_user": "mm",
            "soft_min": "mm",
            "soft_max": "mm",
        }
        op = json_of(
            await api.client.post("/axes/x/move?wait=true", json={"position": 1, "unit": "user"})
        )
        assert op["units"] == {
            "target": "pulse",
            "target_user": "mm",
            "position": "pulse",
            "position_user": "mm",
        }
        assert (op["target"], op["target_user"]) == (100, 1.0)
        entry = json_of(await api.client.get("/controllers/sim.1/positions/0"))
        assert entry["unit"] == "pulse"


async def test_speed_of_motor_2_while_motor_1_moves_is_409_and_nothing_is_sent() -> None:
    async with running_app(scale=5.0) as api:
        await api.client.post("/axes/x/move", json={"position": 90_000, "unit": "pulse"})
        await api.until(lambda: api.cached("1").moving)
        mark = api.mark()
        r = await api.client.get("/axes/sim.1.2/speed")
        assert r.status_code == 409, r.text
        problem = r.json()
        assert "§10 F" in problem["detail"] and problem["field"] == "axis"
        assert not any(t.startswith(("F", "OH", "OL", "OS", "OC")) for t in api.heard("1", mark))
        await api.client.post("/axes/x/stop")


async def test_with_wait_an_unknown_outcome_is_a_504_problem_carrying_the_operation() -> None:
    # The line is cut in the middle of a move: the controller cannot tell how it ended.
    async with running_app(scale=5.0) as api:
        waiting = asyncio.ensure_future(
            api.client.post("/axes/x/move?wait=true", json={"position": 60_000, "unit": "pulse"})
        )
        await api.until(lambda: api.cached("1").moving)
        Controls(api.sim).cut(True)
        r = await asyncio.wait_for(waiting, 30)
        Controls(api.sim).cut(False)
        assert r.status_code == 504, r.text  # was 200 with state unknown
        problem = r.json()
        assert problem["type"] == "urn:rc233-gateway:problem:motion-unknown"
        assert problem["outcome"] == "unknown"
        assert problem["operation"]["state"] == "unknown"
        assert r.headers["location"].endswith(problem["operation"]["id"])
