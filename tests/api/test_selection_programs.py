"""What a user program does to the motor selection (§10 F, §10 G): a program that selects and
moves motor 2 leaves motor 2 selected, with no frame of the gateway's; the next per-motor
command of the gateway selects its own motor again with F before it acts."""

from __future__ import annotations

from gateway.bus.state_types import Change
from tests.support.sim_app import Api, running_app

PROGRAM = "/controllers/sim.1/program"
#: Select motor 2, its position data 300, move there and wait for the end (§12), end.
MOTOR_2_PROGRAM = "/F2/2300/3///END"


def program_ended(api: Api) -> bool:
    state = api.device("1").snapshot(api.sim.act(lambda now: now))
    return not state["axes"]["2"]["moving"] and api.position("1", 2) == 300


async def test_after_a_program_moved_motor_2_a_rest_move_of_motor_1_selects_motor_1() -> None:
    async with running_app() as api:
        await api.identified()
        # The gateway knows motor 1 selected (its own F, read back).
        r = await api.client.post(
            "/controllers/sim.1/commands", params={"motor": 1}, json={"command": "OH"}
        )
        assert r.status_code == 200, r.text
        assert api.runtime.state.controller("sim", "1").selection_confirmed
        r = await api.client.put(PROGRAM, json={"text": MOTOR_2_PROGRAM})
        assert r.status_code == 200, r.text
        r = await api.client.post(f"{PROGRAM}/run", json={})
        assert r.status_code == 200, r.text
        await api.until(lambda: program_ended(api), timeout=30)
        mark = api.mark()
        move = await api.client.post(
            "/axes/sim.1.1/move", params={"wait": "true"}, json={"position": 250, "unit": "pulse"}
        )
        assert move.status_code == 200, move.text
        assert move.json()["state"] == "done", move.text
        heard = api.heard(since=mark)
        assert "F1" in heard, heard  # selected explicitly on the wire
        # Before the move (``3``: to the position data, the selected motor's, §10 3)
        assert heard.index("F1") < heard.index("3"), heard
        assert api.position("1", 1) == 250  # motor 1 moved
        assert api.position("1", 2) == 300  # the conveyor stayed


async def test_a_programs_motion_is_shown_on_the_motor_that_moves() -> None:
    async with running_app() as api:
        await api.identified()
        r = await api.client.post(
            "/controllers/sim.1/commands", params={"motor": 1}, json={"command": "OH"}
        )
        assert r.status_code == 200, r.text  # motor 1 selected, and known so
        changes: list[Change] = []
        stop = api.runtime.state.changes.subscribe(changes.append)
        try:
            r = await api.client.put(PROGRAM, json={"text": "/F2/240000/3///END"})
            assert r.status_code == 200, r.text
            r = await api.client.post(f"{PROGRAM}/run", json={})
            assert r.status_code == 200, r.text
            await api.until(lambda: api.position("1", 2) == 40000, timeout=60)
            await api.until(lambda: not api.runtime.state.axis("sim", "1", 2).moving, timeout=30)
        finally:
            stop()
        one = [dict(c.values) for c in changes if (c.body, c.motor) == ("1", 1)]
        two = [dict(c.values) for c in changes if (c.body, c.motor) == ("1", 2)]
        assert any(v.get("moving") is True for v in two), two
        assert not any(v.get("moving") is True for v in one), one
        assert not any("position" in v for v in one), one  # motor 1 stood at 0 all along
        assert api.position("1", 1) == 0


async def test_after_a_raw_f2_a_rest_move_of_motor_1_selects_motor_1() -> None:
    async with running_app() as api:
        await api.identified()
        r = await api.client.post(
            "/controllers/sim.1/commands", params={"motor": 1}, json={"command": "OH"}
        )
        assert r.status_code == 200, r.text  # motor 1 selected, and known so
        r = await api.client.post("/loops/sim/raw", json={"controller": "1", "text": "F2"})
        assert r.status_code == 200 and r.json()["outcome"] == "done", r.text
        mark = api.mark()
        move = await api.client.post(
            "/axes/sim.1.1/move", params={"wait": "true"}, json={"position": 250, "unit": "pulse"}
        )
        assert move.status_code == 200, move.text
        heard = api.heard(since=mark)
        assert "F1" in heard and heard.index("F1") < heard.index("3"), heard
        assert (api.position("1", 1), api.position("1", 2)) == (250, 0)
