"""Operations in memory stay at their bound; older ones are still served from the state store."""

from __future__ import annotations

import asyncio
import gc
import weakref

from gateway.service.operations.book import MEMORY
from tests.support.sim_app import json_of, running_app


def test_the_default_depth_is_what_the_api_serves_fast():
    assert MEMORY == 1_000


async def test_memory_keeps_its_bound_and_older_operations_come_from_the_store() -> None:
    async with running_app() as api:
        api.operations.retention = 3  # the bound, small enough to pass it with real moves
        ids = []
        for n in range(7):
            axis = "x" if n % 2 else "z"
            r = await api.client.post(f"/axes/{axis}/step?wait=true", json={"direction": "cw"})
            assert r.status_code == 200, r.text
            ids.append(json_of(r)["id"])
        await api.runtime.store.run(lambda c: None)  # the posted state writes are done
        kept = api.operations.list(limit=100)
        assert len(kept) == 3
        # an ended operation keeps what it did, not the command models it sent
        assert all(op.final and op.commands == () and op.frames for op in kept)
        assert api.operations.forgotten == 4
        first = await api.client.get(f"/operations/{ids[0]}")
        assert first.status_code == 200, first.text
        assert (json_of(first)["id"], json_of(first)["state"]) == (ids[0], "done")
        listed = json_of(await api.client.get("/operations", params={"limit": 100}))
        assert [o["id"] for o in listed] == ids[::-1]
        only_x = json_of(await api.client.get("/operations", params={"axis": "x"}))
        assert [o["id"] for o in only_x] == ids[1::2][::-1]
        two = json_of(await api.client.get("/operations", params={"limit": 5}))
        assert [o["id"] for o in two] == ids[::-1][:5]
        unknown = await api.client.get("/operations/op-99999-00000000")
        assert unknown.status_code == 404


async def test_a_forgotten_operation_lets_go_of_its_finished_event() -> None:
    # Each operation owns an asyncio.Event that ``?wait=true`` waits on; it must leave memory
    # with its operation, or the API process keeps one event a move for ever.
    async with running_app() as api:
        api.operations.retention = 2
        events: list[weakref.ref[asyncio.Event]] = []
        for n in range(6):
            axis = "x" if n % 2 else "z"
            r = await api.client.post(f"/axes/{axis}/step?wait=true", json={"direction": "cw"})
            assert r.status_code == 200, r.text
            events.append(weakref.ref(api.operations.get(json_of(r)["id"]).finished))
        await api.runtime.store.run(lambda c: None)
        gc.collect()
        alive = [ref() is not None for ref in events]
        assert alive == [False] * 4 + [True] * 2  # the two kept ones only
