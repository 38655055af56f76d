"""A jog whose loop went down while it ran is stopped (``SS``) once the loop is up again: its
holder's release could not reach it through the cut line, and the controller would go on
jogging with nobody holding it.

Through the serial path: the simulated loop behind the in-process line, the line cut and
restored with the simulator's own control (``set_cut``)."""

from __future__ import annotations

import asyncio
import logging
from typing import Any

import pytest

from gateway.errors import ConflictError
from gateway.service.events import EventKind, ServiceEvent
from gateway.service.operations import durable
from gateway.service.operations.asked import StepAsked
from gateway.service.operations.terms import Direction
from gateway.service.operations.types import OperationState
from gateway.sim.control import Controls
from tests.support.sim_app import Api, json_of, running_app

WAIT = 30.0


async def until_event(api: Api, check: Any, timeout: float = WAIT) -> None:
    """Wait until ``check()`` holds, woken by every service event (no sleeping)."""
    seen = asyncio.Event()
    stop = api.runtime.events.subscribe(lambda _e: seen.set())
    try:
        async with asyncio.timeout(timeout):
            while not check():
                seen.clear()
                await seen.wait()
    finally:
        stop()


def operation_states(events: list[ServiceEvent], ident: str) -> list[str]:
    """The states of operation ``ident`` as the event feed (the WebSocket's source) gave them."""
    return [
        str(e.data["state"])
        for e in events
        if e.kind is EventKind.OPERATION and e.data.get("id") == ident
    ]


def jogging(api: Api, body: str = "1", motor: int = 1) -> bool:
    """Whether the simulated motor turns now (the device's own word, not the gateway's)."""
    seen: list[bool] = []
    device = api.device(body)
    api.sim.act(lambda now: seen.append(bool(device.snapshot(now)["axes"][str(motor)]["moving"])))
    return seen[0]


async def test_a_jog_whose_line_was_cut_is_stopped_when_the_loop_comes_back() -> None:
    async with running_app() as api:
        # OL 500 pps toward the soft maximum (94,000): minutes of device time, still jogging
        # when the line comes back however loaded the host.
        r = await api.client.post("/axes/x/jog", json={"direction": "cw", "speed": "low"})
        assert r.status_code == 202, r.text
        ident = json_of(r)["id"]
        await api.until(lambda: api.operations.get(ident).state is OperationState.MOVING)
        api.sim.act(lambda now: api.sim.set_cut(True, now))
        # The loop goes down and the jog ends unknown: nobody can tell what the axis does.
        await until_event(api, lambda: api.operations.get(ident).state is OperationState.UNKNOWN)
        lost = json_of(await api.client.get(f"/operations/{ident}"))
        assert lost["state"] == "unknown" and lost["error"]["kind"] == "loop_down", lost
        assert jogging(api)  # the controller never heard a stop: it jogs on, unheld
        # While the line is down, a new motion there is told to come back later (503), as
        # any request that needs the line.
        r = await api.client.post("/axes/y/move", json={"position": 5, "unit": "pulse"})
        assert r.status_code == 503, r.text
        mark = api.mark()
        api.sim.act(lambda now: api.sim.set_cut(False, now))
        # Once the loop is up: SS (§10 SS, the decelerating stop), and the axis stops.
        await until_event(api, lambda: "SS" in api.heard("1", mark))
        await until_event(
            api, lambda: api.operations.get(ident).state is not OperationState.UNKNOWN
        )
        assert not jogging(api)
        assert api.heard("1", mark).count("SS") == 1 and "S" not in api.heard("1", mark)
        # The final truth, at GET /operations/{id} and in the event feed.
        final = json_of(await api.client.get(f"/operations/{ident}"))
        assert final["state"] == "failed", final
        assert final["position"] == api.position("1", 1) > 0
        assert final["error"]["kind"] == "loop_down" and final["error"]["outcome"] == "not_done"
        assert "$1SS" in final["error"]["detail"], final["error"]
        assert operation_states(api.events, ident)[-2:] == ["unknown", "failed"]
        # The controller is free again: a new jog there is taken.
        r = await api.client.post("/axes/x/jog", json={"direction": "ccw", "speed": "low"})
        assert r.status_code == 202, r.text
        await api.client.post("/axes/x/stop", json={"mode": "decelerate"})
        # Audited as a stop no request made.
        entries = json_of(await api.client.get("/audit"))["entries"]
        stops = [e for e in entries if e.get("event") == "linkup_stop"]
        assert [(s["bytes_sent"], s["result"], s["operation"]) for s in stops] == [
            (["$1SS"], "done", ident)
        ], stops


async def test_a_jog_whose_controller_alone_went_silent_is_stopped_when_it_answers_again() -> None:
    # Its own wiring on the current loop broken: the controller hears every frame and executes
    # it, its replies are lost (the simulator's ``drop`` fault on body 1 alone). The loop stays
    # up, controllers 2 and 3 answer; the jog goes on with nobody able to reach it.
    async with running_app() as api:
        controls = Controls(api.sim)
        r = await api.client.post("/axes/x/jog", json={"direction": "cw", "speed": "low"})
        assert r.status_code == 202, r.text
        ident = json_of(r)["id"]
        await api.until(lambda: api.operations.get(ident).state is OperationState.MOVING)
        controls.fault("drop", body="1", probability=1.0)
        await until_event(api, lambda: api.operations.get(ident).state is OperationState.UNKNOWN)
        lost = json_of(await api.client.get(f"/operations/{ident}"))
        assert lost["state"] == "unknown" and lost["error"]["kind"] == "offline", lost
        assert api.runtime.ready()  # the loop itself is up
        assert jogging(api)
        # Silent is not switched off: the gateway does not say the controller stands still.
        assert api.cached("1").online is False and api.cached("1").moving is None
        mark = api.mark()
        controls.clear_faults(body="1")
        await until_event(api, lambda: "SS" in api.heard("1", mark))
        await until_event(
            api, lambda: api.operations.get(ident).state is not OperationState.UNKNOWN
        )
        assert not jogging(api)
        assert api.heard("1", mark).count("SS") == 1 and "S" not in api.heard("1", mark)
        final = json_of(await api.client.get(f"/operations/{ident}"))
        assert final["state"] == "failed", final
        assert final["position"] == api.position("1", 1) > 0
        assert final["error"]["kind"] == "offline" and final["error"]["outcome"] == "not_done"
        assert "controller " in final["error"]["detail"] and "$1SS" in final["error"]["detail"]
        entries = json_of(await api.client.get("/audit"))["entries"]
        stops = [e for e in entries if e.get("event") == "answer_stop"]
        assert [(s["bytes_sent"], s["result"], s["operation"]) for s in stops] == [
            (["$1SS"], "done", ident)
        ], stops


async def test_a_move_whose_line_was_cut_is_not_stopped_when_the_loop_comes_back() -> None:
    # A finite motion ends by itself: the restored line gets no stop for it.
    async with running_app() as api:
        # Slow (600 pps: 150 device seconds, 3 s of real time here), so that it is still
        # running, and seen running, when the line is cut, however busy the host.
        r = await api.client.put("/axes/x/speed", json={"oh": 600})
        assert r.status_code == 200, r.text
        r = await api.client.post(
            "/axes/x/move", json={"position": 90000, "relative": True, "unit": "pulse"}
        )
        assert r.status_code in (200, 202), r.text
        ident = json_of(r)["id"]
        await api.until(lambda: api.operations.get(ident).state is OperationState.MOVING)
        api.sim.act(lambda now: api.sim.set_cut(True, now))
        await until_event(api, lambda: api.operations.get(ident).state is OperationState.UNKNOWN)
        mark = api.mark()
        api.sim.act(lambda now: api.sim.set_cut(False, now))
        await api.until(lambda: api.runtime.ready() and api.cached("1").online is True)
        # The poller's reads after the link-up have gone out; a stop would have gone first.
        await until_event(api, lambda: len(api.heard("1", mark)) >= 3)
        assert "SS" not in api.heard("1", mark) and "S" not in api.heard("1", mark)


async def test_a_jog_whose_stop_is_not_taken_after_the_outage_stays_unknown(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    # Controller 1 lost its power during the outage: the loop comes back (2 and 3 answer), the
    # stop is tried for the read-back's time (shortened here) and never taken; in the end
    # nobody claims the axis stopped.
    monkeypatch.setattr(durable, "RESTART_READ_BACK", 6.0)
    caplog.set_level(logging.ERROR, "gateway.service")
    async with running_app() as api:
        r = await api.client.post("/axes/x/jog", json={"direction": "cw", "speed": "low"})
        assert r.status_code == 202, r.text
        ident = json_of(r)["id"]
        await api.until(lambda: api.operations.get(ident).state is OperationState.MOVING)
        api.sim.act(lambda now: api.sim.set_cut(True, now))
        await until_event(api, lambda: api.operations.get(ident).state is OperationState.UNKNOWN)
        first = api.operations.get(ident).error
        # Until its stop and read-back are done, its controller takes no new motion (the SS
        # would stop it, and the read-back would judge it): refused before anything is sent.
        # (Over HTTP the dead loop answers 503 first, and after the link-up the controller off.)
        with pytest.raises(ConflictError, match=ident):
            await api.operations.run(
                api.runtime.topology.axis("y"),
                StepAsked(direction=Direction.CW),
                (),
                motor=2,
                holder="test",
            )
        Controls(api.sim).power("1", False)
        api.sim.act(lambda now: api.sim.set_cut(False, now))

        def said() -> bool:
            error = api.operations.get(ident).error
            return error is not None and error is not first

        await until_event(api, said)
        final = json_of(await api.client.get(f"/operations/{ident}"))
        assert final["state"] == "unknown" and final["error"]["kind"] == "loop_down", final
        assert "may still be moving" in final["error"]["detail"], final["error"]
        entries = json_of(await api.client.get("/audit"))["entries"]
        stops = [e for e in entries if e.get("event") == "linkup_stop"]
        assert len(stops) == 1 and stops[0]["result"] != "done" and stops[0]["error"], stops
    assert "ran while its loop was down and could not be stopped" in caplog.text, caplog.text
