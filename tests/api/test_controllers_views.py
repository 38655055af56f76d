"""GET /controllers, /controllers/{id} (cached, or fresh)."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from gateway.service.controllers.service import FRESH_READS
from gateway.service.roles import Role
from tests.support.sim_app import Api, auth, running_app


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app() as running:
        await running.identified()
        yield running


def contains_run(heard: list[str], run: tuple[str, ...]) -> bool:
    return any(tuple(heard[i : i + len(run)]) == run for i in range(len(heard)))


async def test_every_controller_with_its_names_and_axes(api: Api) -> None:
    r = await api.client.get("/controllers")
    assert r.status_code == 200
    views = r.json()
    assert [v["id"] for v in views] == ["sim.1", "sim.2", "sim.3"]
    assert [v["name"] for v in views] == ["gantry", "head", "handler"]
    assert views[0]["axes"] == ["sim.1.1", "sim.1.2"]
    assert all(v["online"] is True and v["mode"] == 0 for v in views)


async def test_by_name_or_id_and_404(api: Api) -> None:
    by_name = (await api.client.get("/controllers/head")).json()
    assert by_name["id"] == "sim.2" and by_name["body"] == "2"
    r = await api.client.get("/controllers/sim.7")
    assert r.status_code == 404
    assert r.headers["content-type"].startswith("application/problem+json")
    assert "sim.7" in r.json()["detail"]


async def test_fresh_reads_the_status_now(api: Api) -> None:
    r = await api.client.post("/controllers/sim.1/commands", json={"command": "E{mode}", "mode": 1})
    assert r.status_code == 200, r.text
    mark = api.mark()
    r = await api.client.get("/controllers/gantry", params={"fresh": "true"})
    assert r.status_code == 200
    assert r.json()["mode"] == 1  # what 94 now reads (§10 9 bits 5,4)
    assert r.json()["program"] == "0"  # GSS: no program has run
    assert contains_run(api.heard(since=mark), tuple(c.wire() for c in FRESH_READS))


async def test_views_are_for_viewers() -> None:
    async with running_app(roles=True) as api:
        viewer = auth(Role.VIEWER)
        assert (await api.client.get("/controllers", headers=viewer)).status_code == 200
        r = await api.client.get("/controllers/sim.1?fresh=true", headers=viewer)
        assert r.status_code == 200
        assert (await api.client.get("/controllers")).status_code == 401
