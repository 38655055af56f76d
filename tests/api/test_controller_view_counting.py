"""The controller view says how the controller counts positions (§10 EP): the dashboard's
soft-limit bar starts at 0 on a controller that counts unsigned."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from tests.support.sim_app import Api, running_app

CMD = "/controllers/sim.1/commands"


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app() as running:
        await running.identified()
        yield running


async def test_the_view_follows_ep_as_it_is_set_and_read(api: Api) -> None:
    view = (await api.client.get("/controllers/sim.1")).json()
    assert view["signed_positions"] in (None, False)  # EP not read yet, or the default EP0
    assert (await api.client.post(CMD, json={"command": "EP1"})).status_code == 200
    assert (await api.client.get("/controllers/sim.1")).json()["signed_positions"] is True
    assert (await api.client.post(CMD, json={"command": "EP0"})).status_code == 200
    assert (await api.client.get("/controllers/sim.1")).json()["signed_positions"] is False
    # read back from the device (EP query, §10 EP): unsigned
    assert (await api.client.post(CMD, json={"command": "EP"})).status_code == 200
    assert (await api.client.get("/controllers/sim.1")).json()["signed_positions"] is False
