"""The user program of a controller: upload, read back, run, status, data, autostart (§10 G-IW).

The programs run in the simulator's interpreter (simulator part II).
"""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from gateway.service.roles import Role
from tests.support.sim_app import Api, auth, running_app

PROGRAM = "/controllers/sim.1/program"
#: The manual's §11 example program, as the gateway writes it (canonical text).
EXAMPLE = "/D00/0//D01B/JON0+1/J-2/D00/25000/3//END"
#: A program that runs until stopped: output 0 ON, then /J-1 jumps to itself (§12 /J).
ENDLESS = "/D01B/J-1/END"


async def output_turns_on(api: Api, bit: int, reads: int = 200) -> bool:
    """Read output ``bit`` (CO{bit}, one line exchange each) until it is ON, ``reads`` at most."""
    for _ in range(reads):
        if (await api.client.get(f"/controllers/sim.1/io/outputs/{bit}")).json()["on"]:
            return True
    return False


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app() as running:
        await running.identified()
        yield running


async def test_upload_then_read_back_gives_the_text(api: Api) -> None:
    mark = api.mark()
    r = await api.client.put(PROGRAM, json={"text": EXAMPLE})
    assert r.status_code == 200, r.text
    assert r.json()["frames"] == ["$1I", EXAMPLE]
    assert r.json()["outcome"] == "done"
    assert api.device().rt.program == EXAMPLE
    heard = api.heard(since=mark)
    assert "I" in heard
    r = await api.client.get(PROGRAM)
    assert r.json() == {
        "controller": "sim.1",
        "text": EXAMPLE,
        "bytes": len(EXAMPLE),
        "steps": 11,
    }  # 11 "/" (§10 GN)
    assert "IR" in api.heard(since=mark)


@pytest.mark.parametrize(
    ("text", "step", "field", "rule"),
    [
        ("D00/END", 0, "body.text", "the first character of a program is '/' (§10 I)"),
        ("/D00/J+5/END", 2, "body.text.jump", "a jump or call lands on a statement"),
        ("/D00/OH99999/END", 2, "body.text.hs", "hs: decimal 1-16383"),
        ("/D00", 0, "body.text", "'/END' is the last statement"),
        ("/CO$1/END", 0, "body.text", "no '$' anywhere in a program"),
        ("/D00/" + "0/" * 2300 + "END", 0, "body.text", "at most 4,416 bytes"),
    ],
)
async def test_a_broken_program_is_refused_with_step_field_and_rule(
    api: Api, text: str, step: int, field: str, rule: str
) -> None:
    mark = api.mark()
    r = await api.client.put(PROGRAM, json={"text": text})
    assert r.status_code == 422, r.text
    problem = r.json()
    assert problem["field"] == field
    assert problem["rule"].startswith(rule) or rule in problem["rule"]
    if step:
        assert problem["step"] == step
    assert "I" not in api.heard(since=mark)  # nothing sent


async def test_status_buffers_and_counters(api: Api) -> None:
    r = await api.client.get(f"{PROGRAM}/status")
    assert r.json() == {"controller": "sim.1", "state": "0", "state_name": "ended", "step": 0}
    r = await api.client.put(f"{PROGRAM}/buffers/B", json={"value": 0x5A})
    assert r.json()["frames"] == ["$1GWB5A"]
    r = await api.client.put(f"{PROGRAM}/counters/2", json={"value": 65535})
    assert r.json()["frames"] == ["$1GW265535"]
    data = (await api.client.get(f"{PROGRAM}/data")).json()
    assert data["buffers"]["B"] == {"value": 0x5A, "hex": "5A", "on": [1, 3, 4, 6]}
    assert data["buffers"]["A"]["value"] == 0
    assert data["counters"] == {"1": 0, "2": 65535}
    r = await api.client.put(f"{PROGRAM}/counters/3", json={"value": 1})
    assert r.status_code == 422 and r.json()["field"] == "path.counter"
    r = await api.client.put(f"{PROGRAM}/buffers/G", json={"value": 1})
    assert r.status_code == 422 and r.json()["field"] == "path.buffer"
    r = await api.client.put(f"{PROGRAM}/counters/1", json={"value": 65536})
    assert r.status_code == 422 and r.json()["field"] == "body.value"


async def test_autostart(api: Api) -> None:
    assert (await api.client.get(f"{PROGRAM}/autostart")).json() == {"enabled": False}
    r = await api.client.put(f"{PROGRAM}/autostart", json={"enabled": True})
    assert r.json()["frames"] == ["$1GAS"]
    assert (await api.client.get(f"{PROGRAM}/autostart")).json() == {"enabled": True}
    r = await api.client.put(f"{PROGRAM}/autostart", json={"enabled": False})
    assert r.json()["frames"] == ["$1GAR"]


async def test_run_sends_g_then_reads_the_state(api: Api) -> None:
    mark = api.mark()
    r = await api.client.post(f"{PROGRAM}/run", json={"label": "1"})
    assert r.status_code == 200, r.text
    assert r.json()["frames"] == ["$1G1", "$1GSS"]
    assert [x["form"] for x in r.json()["results"]] == ["G{lb}", "GSS"]
    heard = api.heard(since=mark)
    assert heard[heard.index("G1") + 1] == "GSS"
    r = await api.client.post(f"{PROGRAM}/run", json={"label": "S"})  # G+S would be GS
    assert r.status_code == 422 and r.json()["field"] == "body.label"
    r = await api.client.post(f"{PROGRAM}/run", json={"label": "a"})  # §10 G: not a-z
    assert r.status_code == 422
    assert "GS" not in api.heard(since=mark) and "Ga" not in api.heard(since=mark)


async def test_pause_resume_and_stop_send_their_commands(api: Api) -> None:
    mark = api.mark()
    assert (await api.client.post(f"{PROGRAM}/pause")).json()["frames"] == ["$1GS"]
    assert (await api.client.post(f"{PROGRAM}/resume")).json()["frames"] == ["$1GC"]
    assert (await api.client.post(f"{PROGRAM}/stop")).json()["frames"] == ["$1GE"]
    r = await api.client.post(f"{PROGRAM}/stop", json={"mode": "immediate"})
    assert r.json()["frames"] == ["$1GES"]
    heard = api.heard(since=mark)
    # (the poller's GSS reads go on meanwhile)
    assert [t for t in heard if t in ("GS", "GC", "GE", "GES")] == ["GS", "GC", "GE", "GES"]


async def test_stop_is_never_refused_by_a_lease(api: Api) -> None:
    api.leases.acquire("sim.1", "someone-else", 60)
    assert (await api.client.post(f"{PROGRAM}/stop", json={"mode": "immediate"})).status_code == 200
    assert (await api.client.post(f"{PROGRAM}/stop")).status_code == 200
    r = await api.client.post(f"{PROGRAM}/run")
    assert r.status_code == 409 and r.json()["holder"] == "someone-else"
    r = await api.client.put(PROGRAM, json={"text": ENDLESS})
    assert r.status_code == 409


async def test_roles_of_program_routes() -> None:
    async with running_app(roles=True) as api:
        op = auth(Role.OPERATOR)
        mark = api.mark()
        assert (
            await api.client.put(PROGRAM, json={"text": ENDLESS}, headers=op)
        ).status_code == 403
        r = await api.client.put(f"{PROGRAM}/autostart", json={"enabled": True}, headers=op)
        assert r.status_code == 403
        assert not {"I", "GAS"} & set(api.heard(since=mark))
        assert (await api.client.post(f"{PROGRAM}/stop", headers=op)).status_code == 200
        viewer = auth(Role.VIEWER)
        assert (await api.client.post(f"{PROGRAM}/run", headers=viewer)).status_code == 403
        admin = auth(Role.ADMIN)
        assert (
            await api.client.put(PROGRAM, json={"text": ENDLESS}, headers=admin)
        ).status_code == 200


# ---------------------------------------------------------------------- simulator part II


async def test_a_program_runs_pauses_resumes_and_ends(api: Api) -> None:
    assert (await api.client.put(PROGRAM, json={"text": ENDLESS})).status_code == 200
    r = await api.client.post(f"{PROGRAM}/run")
    assert r.status_code == 200
    assert r.json()["results"][1]["value"] == "1"  # GSS right after G: running
    assert await output_turns_on(api, 0)
    await api.client.post(f"{PROGRAM}/pause")
    assert (await api.client.get(f"{PROGRAM}/status")).json()["state"] == "P"
    await api.client.post(f"{PROGRAM}/resume")
    assert (await api.client.get(f"{PROGRAM}/status")).json()["state"] == "1"
    await api.client.post(f"{PROGRAM}/stop")
    status = (await api.client.get(f"{PROGRAM}/status")).json()
    assert status["state"] == "0"


async def test_while_a_program_runs_upload_and_run_are_409(api: Api) -> None:
    await api.client.put(PROGRAM, json={"text": ENDLESS})
    await api.client.post(f"{PROGRAM}/run")
    await api.client.get("/controllers/sim.1", params={"fresh": "true"})  # GSS: running
    mark = api.mark()
    r = await api.client.put(PROGRAM, json={"text": EXAMPLE})
    assert r.status_code == 409 and "§11-3" in r.json()["detail"]
    assert (await api.client.post(f"{PROGRAM}/run")).status_code == 409
    r = await api.client.post("/controllers/sim.1/eeprom/save", json={"area": "settings"})
    assert r.status_code == 409
    assert not {"I", "G", "DW"} & set(api.heard(since=mark))
    r = await api.client.post(f"{PROGRAM}/stop", json={"mode": "immediate"})
    assert r.status_code == 200


async def test_run_from_a_label(api: Api) -> None:
    # D00 before the label is skipped: output 0 set beforehand stays ON (§10 G{lb}).
    await api.client.put(PROGRAM, json={"text": "/D00/G1/D21B/J-1/END"})
    await api.client.put("/controllers/sim.1/io/outputs", json={"value": 1})
    r = await api.client.post(f"{PROGRAM}/run", json={"label": "1"})
    assert r.status_code == 200
    assert await output_turns_on(api, 2)
    assert (await api.client.get("/controllers/sim.1/io/outputs/0")).json()["on"] is True
    await api.client.post(f"{PROGRAM}/stop")
