"""Changing a loop's baud rate through the simulated line: ES to every controller (its '>' at
the old rate), the port reopened at the new one, each controller read there; a controller that
does not follow makes the others go back."""

from __future__ import annotations

import asyncio

from gateway.bus.events import LinkDown
from gateway.sim.control import Controls
from tests.support.sim_app import WAIT, Api, auth, json_of, running_app


def _rates(api: Api) -> dict[str, int]:
    """Each simulated controller's rate (what its UART runs at) and the line's (the host's)."""
    rates = {u.name: int(u.bps) for u in api.sim.units}
    return {**rates, "host": int(api.sim.baud)}


async def _move_x(api: Api) -> None:
    mark = api.mark()
    r = await api.client.post(
        "/axes/x/move?wait=true", json={"position": 3, "unit": "user"}, headers=auth("operator")
    )
    assert r.status_code == 200, r.text
    assert "3" in api.heard("1", mark)


async def test_every_controller_and_the_port_move_to_the_new_rate_and_back() -> None:
    async with running_app(("1", "2"), roles=True) as api:
        assert _rates(api) == {"1": 9600, "2": 9600, "host": 9600}
        mark = api.mark()
        r = await api.client.post("/loops/sim/baud", json={"baud": 1200}, headers=auth("admin"))
        assert r.status_code == 200, r.text
        body = json_of(r)
        assert body["outcome"] == "done" and body["baud"] == 1200 and body["previous"] == 9600
        assert [(c["controller"], c["result"], c["baud"]) for c in body["controllers"]] == [
            ("sim.1", "moved", 1200),
            ("sim.2", "moved", 1200),
        ]
        assert "baud = 1200" in body["configuration"]
        assert "ES1" in api.heard("1", mark) and "ES1" in api.heard("2", mark)
        assert _rates(api) == {"1": 1200, "2": 1200, "host": 1200}
        loop = json_of(await api.client.get("/loops/sim", headers=auth("viewer")))
        assert loop["baud"] == 1200 and loop["up"] is True
        await api.until(lambda: api.cached("2").online is True)
        await _move_x(api)  # the loop works at the new rate

        r = await api.client.post("/loops/sim/baud", json={"baud": 9600}, headers=auth("admin"))
        assert r.status_code == 200 and json_of(r)["outcome"] == "done", r.text
        assert _rates(api) == {"1": 9600, "2": 9600, "host": 9600}
        await _move_x(api)

        audit = json_of(await api.client.get("/audit?limit=200", headers=auth("admin")))
        changes = [
            e
            for e in audit["entries"]
            if e["path"].endswith("/loops/sim/baud") and e.get("event") != "intent"
        ]
        assert [(e["status"], e["result"], e["bytes_sent"]) for e in changes] == [
            (200, "done", ["$1ES1", "$2ES1"]),
            (200, "done", ["$1ES0", "$2ES0"]),
        ]


async def test_a_controller_that_does_not_answer_at_the_new_rate_sends_the_others_back() -> None:
    async with running_app(("1", "2"), roles=True) as api:
        # The poller off first, so that the armed fault meets the ES frame: controller 2 takes
        # its ES1 (written to its EEPROM, §10 ES), answers '>' and loses its power for long.
        await api.runtime.pollers["sim"].stop()
        Controls(api.sim).fault("power", body="2", shots=1, hold=100_000.0)
        mark = api.mark()
        r = await api.client.post("/loops/sim/baud", json={"baud": 1200}, headers=auth("admin"))
        assert r.status_code == 200, r.text
        body = json_of(r)
        assert body["outcome"] == "failed" and body["baud"] == 9600, body
        results = {c["controller"]: (c["result"], c["baud"]) for c in body["controllers"]}
        assert results == {"sim.1": ("rolled_back", 9600), "sim.2": ("lost", None)}
        lost = next(c for c in body["controllers"] if c["controller"] == "sim.2")
        assert "body switch F" in lost["detail"]
        heard_1 = [t for t in api.heard("1", mark) if t.startswith("ES")]
        assert heard_1 == ["ES1", "ES0"]  # moved, then sent back at the new rate
        assert [t for t in api.heard("2", mark) if t.startswith("ES")] == ["ES1"]
        # (Controller 2, off, has no rate of its own until it is powered again: its EEPROM's.)
        assert {k: v for k, v in _rates(api).items() if k != "2"} == {"1": 9600, "host": 9600}
        await _move_x(api)  # the rest of the loop works at the old rate

        # Powered again, controller 2 runs at the rate in its EEPROM: silent on this loop.
        Controls(api.sim).power("2", True)
        await api.until(lambda: api.cached("2").online is False)
        assert _rates(api)["2"] == 1200


async def test_bad_rates_and_roles_are_refused_before_anything_is_sent() -> None:
    async with running_app(("1",), roles=True) as api:
        await api.runtime.pollers["sim"].stop()
        mark = api.mark()
        for baud in (4800, 9600, "1200"):
            r = await api.client.post("/loops/sim/baud", json={"baud": baud}, headers=auth("admin"))
            assert r.status_code == 422, r.text
            assert json_of(r)["field"] == "body.baud"
        for who in ("viewer", "operator"):
            r = await api.client.post("/loops/sim/baud", json={"baud": 1200}, headers=auth(who))
            assert r.status_code == 403, r.text
        r = await api.client.put(
            "/controllers/sim.1/control", json={"state": "local"}, headers=auth("admin")
        )
        r = await api.client.post("/loops/sim/baud", json={"baud": 1200}, headers=auth("admin"))
        assert r.status_code == 409 and "local control" in json_of(r)["detail"], r.text
        assert not [t for t in api.heard("1", mark) if t.startswith("ES")]
        assert _rates(api) == {"1": 9600, "host": 9600}


async def test_the_loop_is_held_while_its_rate_changes() -> None:
    async with running_app(("1",), roles=True) as api:
        scheduler = api.runtime.scheduler("sim")
        reopening = asyncio.Event()
        scheduler.events.subscribe(lambda e: reopening.set() if isinstance(e, LinkDown) else None)
        change = asyncio.create_task(
            api.client.post("/loops/sim/baud", json={"baud": 300}, headers=auth("admin"))
        )
        await asyncio.wait_for(reopening.wait(), WAIT)  # the ES went out, the port reopens
        mark = api.mark()
        r = await api.client.post(
            "/axes/x/move", json={"position": 3, "unit": "user"}, headers=auth("operator")
        )
        assert r.status_code == 409, r.text
        assert "baud rate is being changed" in json_of(r)["detail"]
        r = await api.client.post("/loops/sim/baud", json={"baud": 1200}, headers=auth("admin"))
        assert r.status_code == 409, r.text
        done = await change
        assert done.status_code == 200 and json_of(done)["outcome"] == "done", done.text
        assert not [t for t in api.heard("1", mark) if t[:1] in ("2", "3")]
        assert _rates(api) == {"1": 300, "host": 300}
        await _move_x(api)  # released afterwards, and the loop works at 300 bps
