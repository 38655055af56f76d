"""The I/O ports of a controller: read, set, pulse (§10 C, CA, CO, COA, D, DA, P)."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from tests.support.sim_app import Api, running_app

URL = "/controllers/sim.1/io"


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app() as running:
        await running.identified()
        yield running


async def test_outputs_set_then_read_in_mode_0(api: Api) -> None:
    mark = api.mark()
    r = await api.client.put(f"{URL}/outputs", json={"value": 0xA5})
    assert r.status_code == 200, r.text
    assert r.json()["frames"] == ["$1DA5"]  # D DU DL (§10 D form I)
    view = (await api.client.get(URL)).json()
    assert view["outputs"] == {"value": 0xA5, "hex": "A5", "on": [0, 2, 5, 7]}
    assert view["inputs"]["value"] == 0
    assert view["clr1"] is False and view["inp1"] is False  # modes 0, 1: CA and COA
    heard = api.heard(since=mark)
    assert heard.index("CA") < heard.index("COA")


async def test_outputs_with_clr_and_single_bits(api: Api) -> None:
    r = await api.client.put(f"{URL}/outputs", json={"value": 0x0F, "clr1": True, "clr2": False})
    assert r.json()["frames"] == ["$1DA10F"]  # DC bit 0 = CLR1 (§10 D form IV)
    view = (await api.client.get(URL)).json()
    assert view["clr1"] is True and view["clr2"] is False
    r = await api.client.put(f"{URL}/outputs/7", json={"on": True})
    assert r.json()["frames"] == ["$1D71B"]
    r = await api.client.put(f"{URL}/outputs/0", json={"on": False})
    assert r.json()["frames"] == ["$1D00B"]
    r = await api.client.put(f"{URL}/outputs/9", json={"on": True})  # CLR2 as an output
    assert r.json()["frames"] == ["$1D91B"]
    view = (await api.client.get(URL)).json()
    assert view["outputs"]["on"] == [1, 2, 3, 7]
    assert view["clr2"] is True
    assert (await api.client.get(f"{URL}/outputs/7")).json()["on"] is True
    assert (await api.client.get(f"{URL}/outputs/0")).json()["on"] is False
    assert (await api.client.get(f"{URL}/inputs/3")).json() == {
        "controller": "sim.1",
        "bit": 3,
        "on": False,
    }


async def test_pulse_output(api: Api) -> None:
    # 3,000 x 100 ms (§10 P): 300 s of device time, still ON when read back however slow
    # the host is at the tests' time scale.
    r = await api.client.post(f"{URL}/outputs/4/pulse", json={"time": 3000})
    assert r.status_code == 200, r.text
    assert r.json()["frames"] == ["$1P43000"]
    assert (await api.client.get(f"{URL}/outputs/4")).json()["on"] is True
    r = await api.client.post(f"{URL}/outputs/4/pulse", json={"time": 32768})
    assert r.status_code == 422 and r.json()["field"] == "body.time"
    r = await api.client.post(f"{URL}/outputs/8/pulse", json={"time": 1})
    assert r.status_code == 422 and r.json()["field"] == "path.bit"


async def test_mode_2_has_no_clr_or_inp_as_io(api: Api) -> None:
    cmd = "/controllers/sim.1/commands"
    assert (await api.client.post(cmd, json={"command": "E{mode}", "mode": 2})).status_code == 200
    await api.until(lambda: api.cached().mode == 2)
    mark = api.mark()
    view = (await api.client.get(URL)).json()
    assert view["mode"] == 2 and view["clr1"] is None and view["inp1"] is None
    heard = api.heard(since=mark)
    assert "C" in heard and "CO" in heard and "CA" not in heard
    r = await api.client.put(f"{URL}/outputs", json={"value": 1, "clr1": True, "clr2": True})
    assert r.status_code == 422 and "modes 0, 1 only" in r.json()["rule"]  # use DS in mode 2
    r = await api.client.put(f"{URL}/outputs/8", json={"on": True})
    assert r.status_code == 422
    assert not [t for t in api.heard(since=mark) if t.startswith("D")]


@pytest.mark.parametrize(
    ("url", "body", "field"),
    [
        (f"{URL}/outputs", {"value": 256}, "body.value"),
        (f"{URL}/outputs", {"value": 1, "clr1": True}, "body"),
        (f"{URL}/outputs/10", {"on": True}, "path.bit"),
        (f"{URL}/outputs/1", {"on": "maybe"}, "body.on"),
    ],
)
async def test_bad_requests(api: Api, url: str, body: dict, field: str) -> None:
    r = await api.client.put(url, json=body)
    assert r.status_code == 422 and r.json()["field"] == field
    assert (await api.client.get("/controllers/sim.5/io")).status_code == 404
