"""The 24-bit position counter as users see and use it (§7-4, §10 EP, §10 6).

Through the gateway's real serial path to the simulator (in-process pipe). The cell here has
no soft limits, so a jog runs into the scene's CCW limit sensor at -5,000 pulses, past 0: in
unsigned management (EP0, the power-on default) the counter wraps and reads 16,772,216.
"""

from __future__ import annotations

import asyncio
from typing import Any

from gateway.service.config import GatewayConfig, parse_config
from tests.support.sim_app import Api, json_of, running_app

SPAN = 16_777_216  # 2^24
MOVES = ("0", "1", "3", "4", "5", "7", "8", "B")


def free_cell() -> GatewayConfig:
    """Controller 1 with x and y in mm (0.01 mm a pulse) and no soft limits."""
    axes = [
        {"motor": m, "name": n, "unit": "mm", "units_per_pulse": 0.01}
        for m, n in ((1, "x"), (2, "y"))
    ]
    controllers = [{"body": "1", "name": "gantry", "axes": axes}]
    loops = [{"name": "sim", "port": "sim://in-process", "controllers": controllers}]
    return parse_config({"loops": loops}, "test")


def moved(texts: list[str]) -> list[str]:
    return [t for t in texts if t[:1] in MOVES and not t.startswith("BN")]


async def move(api: Api, position: int, *, relative: bool = False, wait: bool = True) -> Any:
    body = {"position": position, "unit": "pulse", "relative": relative}
    params = {"wait": "true", "timeout": "30"} if wait else {}
    return await api.client.post("/axes/x/move", params=params, json=body)


async def test_a_counter_wrapped_below_zero_is_the_negative_position_it_is() -> None:
    async with running_app(("1",), config=free_cell()) as api:
        r = await api.client.post("/axes/x/jog", json={"direction": "ccw", "speed": "high"})
        assert r.status_code in (200, 202), r.text
        jog = json_of(r)["id"]
        await api.until(lambda: api.runtime.state.axis("sim", "1", 1).moving is True)
        # The jog runs into the CCW limit sensor; its operation ends once that is seen, which
        # may be a poll after the axis reads still (a move before that is a 409 "moving").
        await api.operations.wait(jog, 30)
        assert api.runtime.state.axis("sim", "1", 1).moving is False
        view = json_of(await api.client.get("/axes/x", params={"fresh": "true"}))
        counter = api.position("1", 1)  # the simulator's counter, as EP0 reads it
        device = counter - SPAN  # the machine stands past 0, at the CCW limit sensor
        assert -100_000 < device < 0, counter
        assert view["position"] == device, view
        assert view["counter"] == counter
        assert view["position_user"] == round(device * 0.01, 9)
        assert view["units"]["counter"] == "pulse"

        mark = api.mark()
        # Further CCW the counter would wrap again below 0: refused, naming the rule.
        r = await move(api, -1000, relative=True)
        assert r.status_code == 422 and "EP0" in r.json()["rule"], r.text
        # An absolute move from a wrapped counter would travel the long way round (§7-4).
        r = await move(api, 100)
        assert r.status_code == 422 and "absolute move" in r.json()["rule"], r.text
        assert moved(api.heard("1", mark)) == []
        # A relative move back over 0 is what the counter allows: accepted, and it ends there.
        r = await move(api, 1000 - device, relative=True)
        assert r.status_code == 200, r.text
        view = json_of(await api.client.get("/axes/x", params={"fresh": "true"}))
        assert view["position"] == 1000 == view["counter"]


async def test_every_target_the_counter_format_allows_is_accepted_and_the_rest_refused() -> None:
    async with running_app(("1",), config=free_cell()) as api:
        mark = api.mark()
        r = await move(api, 9_000_000, wait=False)  # EP0: 0..16,777,215 (§10 EP)
        assert r.status_code == 202, r.text
        stop = await api.client.post("/axes/x/stop", json={"mode": "immediate"})
        assert stop.status_code == 200, stop.text
        heard = api.heard("1", mark)
        assert "3" in heard[heard.index("29000000") :], heard  # the data, then the move
        # The stopped move's operation ends (a new move waits for it).
        await asyncio.wait_for(api.operations.get(r.json()["id"]).finished.wait(), 30)
        r = await move(api, 16_777_216)
        assert r.status_code == 422, r.text

        r = await api.client.post("/controllers/sim.1/commands", json={"command": "EP1"})
        assert r.status_code == 200, r.text
        mark = api.mark()
        for beyond in (9_000_000, -9_000_000):  # signed: -8,388,608..+8,388,607
            r = await move(api, beyond)
            assert r.status_code == 422, r.text
            assert "-8388608..8388607" in r.json()["rule"]
        assert moved(api.heard("1", mark)) == []
        r = await move(api, -100)
        assert r.status_code == 200, r.text
        assert api.position("1", 1) == -100
