"""Operations answer the same whether the state cache hears the scheduler's events first or last.

``running_app(cache_last=True)`` feeds the cache after every other subscriber of each loop's
scheduler (the poller, the metrics, the state log...). Operations follow the motion through the
cache (``StateCache.follow``), so what they report, and what the axis shows, is the same.
"""

from __future__ import annotations

import pytest

from gateway.service.events import EventKind
from tests.support.sim_app import json_of, running_app


@pytest.mark.parametrize("cache_last", [False, True], ids=["cache first", "cache last"])
async def test_a_move_and_a_step_end_done_where_the_axis_stands(cache_last: bool) -> None:
    async with running_app(cache_last=cache_last) as api:
        r = await api.client.post(
            "/axes/z/move", params={"wait": "true"}, json={"position": 20_000, "unit": "pulse"}
        )
        assert r.status_code == 200, r.text
        op = json_of(r)
        assert (op["state"], op["position"]) == ("done", 20_000)
        assert api.position("2", 1) == 20_000
        states = [
            e.data["state"]
            for e in api.events
            if e.kind is EventKind.OPERATION and e.data["id"] == op["id"]
        ]
        # 20,000 pulses at 5,000 pps: 4 s, seen moving by the status polls on the way.
        assert states[0] == "queued" and "moving" in states and states[-1] == "done"
        axis = json_of(await api.client.get("/axes/z"))
        assert axis["moving"] is False
        # A step too short for any status read to see it turn still ends done, at its end.
        r = await api.client.post("/axes/x/step", params={"wait": "true"}, json={"direction": "cw"})
        assert r.status_code == 200, r.text
        step = json_of(r)
        assert step["state"] == "done" and step["position"] == api.position("1", 1)
