"""What the gateway says about the line is true: a cut line is down (once), a dead loop is no
moving axis, EMS and limits are seen within one status poll.

Times are device seconds (the simulator's clock); the line-cut test runs the simulator only
twice as fast as real time so that "within 2 s" leaves room for a busy machine.
"""

from __future__ import annotations

import asyncio
from typing import Any

import httpx

from gateway.service.events import EventKind, ServiceEvent
from gateway.service.runtime.simulated import SIM_LOOP
from tests.support.sim_app import Api, running_app

#: The line-cut test's simulator speed (device seconds per real second).
CUT_SCALE = 2.0
#: Device seconds the line stays cut.
CUT_HOLD = 8.0
#: The EMS tests' simulator speed, and how soon EMS must be seen: one idle status poll
#: period (1 s) and the transaction in flight when it came due.
EMS_SCALE = 2.0
EMS_SEEN_WITHIN = 1.3


def sim_now(api: Api) -> float:
    """The simulator's clock now (device seconds)."""
    return api.sim.act(lambda now: None)


def link_events(events: list[ServiceEvent], since: int = 0) -> list[dict[str, Any]]:
    """The loop's up/down transitions published since index ``since``."""
    return [dict(e.data) for e in events[since:] if e.kind is EventKind.LINK]


async def until_event(api: Api, check: Any, timeout: float) -> None:
    """Wait until ``check(events)`` holds, woken by every service event (no sleeping)."""
    seen = asyncio.Event()
    stop = api.runtime.events.subscribe(lambda _e: seen.set())
    try:
        async with asyncio.timeout(timeout):
            while not check(api.events):
                seen.clear()
                await seen.wait()
    finally:
        stop()


def assert_503_retry(response: httpx.Response) -> None:
    assert response.status_code == 503, response.text
    assert response.headers["content-type"].startswith("application/problem+json")
    assert int(response.headers["Retry-After"]) >= 1, response.headers


async def test_a_cut_line_is_down_once_answers_503_and_is_ready_when_restored() -> None:
    async with running_app(scale=CUT_SCALE) as api:
        await api.identified()
        mark = len(api.events)
        cut_at = api.sim.act(lambda now: api.sim.cut_for(CUT_HOLD, now))
        # Down within 2 s of the cut, with its cause.
        await until_event(api, lambda ev: link_events(ev, mark), timeout=CUT_HOLD / CUT_SCALE)
        down_at = sim_now(api)
        [down] = link_events(api.events, mark)
        assert down["up"] is False and down["cause"], down
        assert down_at - cut_at <= 2.0, f"down {down_at - cut_at:.2f} s after the cut"
        loop = (await api.client.get("/loops/sim")).json()
        assert loop["up"] is False and loop["cause"]
        assert (await api.client.get("http://localhost/readyz")).status_code == 503
        # Every request that needs the line: 503 + Retry-After at once, stops too.
        for method, path, body in (
            ("POST", "/axes/sim.1.1/move", {"position": 10, "relative": True, "unit": "pulse"}),
            ("POST", "/axes/sim.2.1/stop", None),
            ("GET", "/axes/sim.3.1/speed", None),
        ):
            started = asyncio.get_running_loop().time()
            response = await api.client.request(method, path, json=body)
            assert_503_retry(response)
            assert asyncio.get_running_loop().time() - started < 1.0  # at once, no time-out
        # The line comes back on its own after CUT_HOLD: up (ready) within 2 s of that.
        await until_event(
            api, lambda ev: len(link_events(ev, mark)) >= 2, timeout=2 * CUT_HOLD / CUT_SCALE
        )
        up_at = sim_now(api)
        restored_at = cut_at + CUT_HOLD
        assert up_at >= restored_at, f"up {restored_at - up_at:.2f} s before the line was back"
        assert up_at - restored_at <= 2.0, f"up {up_at - restored_at:.2f} s late"
        assert (await api.client.get("http://localhost/readyz")).status_code == 200
        r = await api.client.get("/axes/sim.3.1/speed")
        assert r.status_code == 200, r.text
        # One down and one up for the outage: no cycling while it lasted.
        assert [e["up"] for e in link_events(api.events, mark)] == [False, True]
        assert api.runtime.scheduler(SIM_LOOP).snapshot().link_downs == 1


async def test_a_dead_loop_is_not_a_moving_axis() -> None:
    async with running_app() as api:
        await api.identified()
        r = await api.client.post(
            "/axes/sim.3.1/move", json={"position": 90000, "relative": True, "unit": "pulse"}
        )
        assert r.status_code in (200, 202), r.text
        await api.until(lambda: api.cached("3").moving)
        mark = len(api.events)
        api.sim.act(lambda now: api.sim.set_cut(True, now))
        await until_event(api, lambda ev: link_events(ev, mark), timeout=20)
        # Nothing the loop last said is current: moving and online unknown, axes stale.
        ctl = api.cached("3")
        assert ctl.moving is None and ctl.online is None
        assert api.runtime.state.axis(SIM_LOOP, "3", 1).stale
        r = await api.client.post(
            "/axes/sim.3.2/move", json={"position": 5, "relative": True, "unit": "pulse"}
        )
        assert_503_retry(r)
        api.sim.act(lambda now: api.sim.set_cut(False, now))


async def test_ems_on_an_idle_controller_is_seen_within_one_status_poll() -> None:
    async with running_app(scale=EMS_SCALE) as api:
        await api.identified()
        pressed_at = api.sim.act(lambda now: api.device("2").set_ems(now, True))
        await api.until(lambda: api.runtime.state.axis(SIM_LOOP, "2", 1).emergency)
        seen_at = sim_now(api)
        # The idle poll period is 1 s; the poll that sees it may be one transaction late.
        late = seen_at - pressed_at
        assert late <= EMS_SEEN_WITHIN, f"EMS seen {late:.2f} s late"
        r = await api.client.get("/axes/sim.2.1")
        assert r.json()["errors"]["emergency"] is True, r.json()


async def test_ems_on_an_idle_controller_is_seen_while_the_others_move() -> None:
    # Slower than the other API tests: the moving controllers' polls fill the line, and the
    # idle one's status poll must still come round within its period.
    async with running_app(scale=EMS_SCALE) as api:
        await api.identified()
        for axis in ("sim.1.1", "sim.3.1"):
            r = await api.client.post(
                f"/axes/{axis}/move", json={"position": 60000, "relative": True, "unit": "pulse"}
            )
            assert r.status_code == 202, r.text
        await api.until(lambda: api.cached("1").moving and api.cached("3").moving)
        pressed_at = api.sim.act(lambda now: api.device("2").set_ems(now, True))
        await api.until(lambda: api.runtime.state.axis(SIM_LOOP, "2", 1).emergency)
        seen_at = sim_now(api)
        assert api.cached("1").moving and api.cached("3").moving  # still moving: it counted
        late = seen_at - pressed_at
        assert late <= EMS_SEEN_WITHIN, f"EMS seen {late:.2f} s late"
        # A moving controller's EMS too, within its moving polls.
        pressed_at = api.sim.act(lambda now: api.device("3").set_ems(now, True))
        await api.until(lambda: api.runtime.state.axis(SIM_LOOP, "3", 1).emergency)
        seen_at = sim_now(api)
        late = seen_at - pressed_at
        assert late <= EMS_SEEN_WITHIN, f"EMS seen {late:.2f} s late"
