"""A position set without motion (§10 R, presets): the cached position is stale from the
command's '>' until it is read back, and then it is the device's."""

from __future__ import annotations

from gateway.bus.state_types import Change
from tests.support.sim_app import running_app


async def test_a_preset_through_commands_is_stale_until_read_back_then_right() -> None:
    async with running_app() as api:
        await api.identified()
        before = (await api.client.get("/axes/sim.1.1")).json()
        assert before["position"] == 0 and before["stale"] is False, before
        changes: list[Change] = []
        stop = api.runtime.state.changes.subscribe(changes.append)
        try:
            r = await api.client.post(
                "/controllers/sim.1/commands",
                params={"motor": 1},
                json={"command": "R{pp}", "pp": 5000},
            )
        finally:
            stop()
        assert r.status_code == 200, r.text
        assert r.json()["outcome"] == "done", r.text
        assert api.position("1", 1) == 5000  # the device's counter
        axis = [dict(c.values) for c in changes if (c.body, c.motor) == ("1", 1)]
        stale = [i for i, v in enumerate(axis) if v.get("stale") is True]
        known = [i for i, v in enumerate(axis) if v.get("position") == 5000]
        assert stale and known, f"never stale, or never 5000: {axis}"
        stale_at, known_at = stale[0], known[0]
        # Stale first, never the old position as fresh; fresh again with the new one.
        assert stale_at < known_at, axis
        assert all(v.get("stale") is not False for v in axis[stale_at:known_at]), axis
        assert axis[known_at].get("stale") is False, axis
        view = (await api.client.get("/axes/sim.1.1")).json()
        assert (view["position"], view["stale"]) == (5000, False), view
        assert (await api.client.get("/axes/sim.1.2")).json()["position"] == 0
