"""Fresh reads shared fairly: a caller's few on the line, the rest from the cache at once."""

from __future__ import annotations

import asyncio

import httpx

from gateway.api.middleware.fresh_reads import CACHE_STATUS, FRESH_PER_CALLER
from gateway.sim.control import Controls
from tests.support.sim_app import WAIT, auth, running_app

CALLS = 10


async def test_one_viewer_cannot_crowd_the_line_with_fresh_reads() -> None:
    async with running_app(roles=True) as api:
        axes = {
            a["name"]: a for a in (await api.client.get("/axes", headers=auth("viewer"))).json()
        }
        # Body 1 stops answering: each fresh read of its axis waits for its time-outs, so the
        # viewer's reads would all be queued at once.
        Controls(api.sim).power("1", False)

        async def fresh(name: str, who: str) -> httpx.Response:
            return await api.client.get(f"/axes/{name}?fresh=true", headers=auth(who))

        tasks = [asyncio.create_task(fresh("x", "viewer")) for _ in range(CALLS)]
        answered: list[httpx.Response] = []
        for ready in asyncio.as_completed(tasks, timeout=WAIT):
            answered.append(await ready)
            if len(answered) == CALLS - FRESH_PER_CALLER:
                break
        # The rest were answered from the cache at once, saying so, with their age.
        assert sum(not t.done() for t in tasks) == FRESH_PER_CALLER
        for response in answered:
            assert response.status_code == 200, response.text
            assert response.headers["cache-status"] == CACHE_STATUS
            assert int(response.headers["age"]) >= 0
            assert response.json()["id"] == axes["x"]["id"]
        # Another caller's fresh read goes to the line, not behind the viewer's.
        other = next(a["name"] for a in axes.values() if not a["id"].startswith("sim.1."))
        own = await fresh(other, "operator")
        assert own.status_code == 200, own.text
        assert "cache-status" not in own.headers
        Controls(api.sim).power("1", True)
        await asyncio.gather(*tasks, return_exceptions=True)
        # With nothing under way, the viewer's next fresh read is read again.
        again = await fresh(other, "viewer")
        assert again.status_code == 200 and "cache-status" not in again.headers
