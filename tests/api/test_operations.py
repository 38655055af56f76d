"""Operations: 202 + Location, their states as events, waiting, final position and errors."""

from __future__ import annotations

from gateway.service.events import EventKind
from gateway.service.operations.types import OperationState
from tests.support.sim_app import json_of, running_app


async def test_202_then_the_operation_reaches_done_with_the_final_position() -> None:
    # at scale 5 the 12 s move lasts 2.4 s of real time: a host slowed by CPU hogs and
    # coverage tracing still polls it moving (at scale 10, 1.2 s, one such run saw it only done)
    async with running_app(scale=5.0) as api:
        r = await api.client.post("/axes/z/move", json={"position": 60_000, "unit": "pulse"})
        assert r.status_code == 202
        op = json_of(r)
        assert op["state"] in ("sent", "moving")
        assert op["frames"] == ["$2260000", "$23"]
        location = r.headers["location"]
        assert location == f"/api/v1/operations/{op['id']}"
        await api.operations.wait(op["id"], 20)
        ended = json_of(await api.client.get(location.removeprefix("/api/v1")))
        assert (ended["state"], ended["position"], ended["target"]) == ("done", 60_000, 60_000)
        assert ended["position"] == api.position("2", 1)
        assert ended["ended"] >= ended["sent"] >= ended["created"]
        # every state change was published on the axis's topic
        states = [
            e.data["state"]
            for e in api.events
            if e.kind is EventKind.OPERATION and e.data["id"] == op["id"]
        ]
        assert states[0] == "queued" and states[1] == "sent" and states[-1] == "done"
        assert {e.topic for e in api.events if e.kind is EventKind.OPERATION} == {"axis:sim.2.1"}
        # a 60,000-pulse move at 5,000 pps lasts 12 s: the 50 ms status polls see it moving
        assert "moving" in states


async def test_a_wait_that_times_out_answers_202_and_the_motion_goes_on() -> None:
    async with running_app() as api:
        r = await api.client.post(
            "/axes/x/jog", params={"wait": "true", "timeout": "0.05"}, json={"direction": "cw"}
        )
        assert r.status_code == 202  # taken and still running: not a server error
        running = json_of(r)
        assert running["state"] in ("sent", "moving")
        assert r.headers["location"].endswith(running["id"])
        op = api.operations.get(running["id"])
        assert not op.final
        # It goes on: seen moving by the gateway's own reads (a stop sent before the jog had
        # turned the motor would leave it where it started: not carried out).
        await api.until(lambda: op.state is OperationState.MOVING)
        await api.client.post("/axes/x/stop")
        await api.operations.wait(op.id, 20)
        assert op.state.value == "done"


async def test_list_and_unknown() -> None:
    async with running_app() as api:
        first = json_of(await api.client.post("/axes/x/step?wait=true", json={"direction": "cw"}))
        second = json_of(await api.client.post("/axes/z/step?wait=true", json={"direction": "cw"}))
        listed = json_of(await api.client.get("/operations"))
        assert [o["id"] for o in listed[:2]] == [second["id"], first["id"]]
        only_x = json_of(await api.client.get("/operations", params={"axis": "x"}))
        assert [o["id"] for o in only_x] == [first["id"]]
        done = json_of(await api.client.get("/operations", params={"state": "failed"}))
        assert done == []
        assert (await api.client.get("/operations/op-0-nothing")).status_code == 404


async def test_a_limit_makes_it_failed() -> None:
    async with running_app() as api:
        # x jogs CW toward its soft maximum (94,000) and runs into the scene's CW limit
        # sensor (65,000 pulses from the power-on position) first
        r = await api.client.post(
            "/axes/x/jog?wait=true", json={"direction": "cw", "speed": "high"}
        )
        assert r.status_code == 409, r.text
        op = r.json()["operation"]
        assert op["state"] == "failed"
        assert op["error"]["kind"] == "limit_error" and "§10" in op["error"]["detail"]


async def test_a_stopped_move_is_failed_with_where_it_stopped() -> None:
    # Time scale 5: the 18 s move lasts 3.6 s here, so the stop lands in it on a loaded host.
    async with running_app(scale=5.0) as api:
        r = await api.client.post("/axes/x/move", json={"position": 90_000, "unit": "pulse"})
        op = json_of(r)
        await api.until(lambda: api.operations.get(op["id"]).state.value == "moving")
        stop = json_of(await api.client.post("/axes/x/stop", json={"mode": "immediate"}))
        assert stop["operation"] == op["id"] and stop["command"] == "S"
        ended = await api.operations.wait(op["id"], 20)
        assert ended.state.value == "failed" and ended.error is not None
        assert ended.error.kind == "stopped"
        assert ended.position == api.position("1", 1) < 90_000
