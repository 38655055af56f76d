"""POST /controllers/{id}/commands: any command of the catalog as a typed body."""

from __future__ import annotations

import re
from collections.abc import AsyncIterator
from typing import Any

import pytest

from gateway.service.roles import Role
from tests.support.sim_app import Api, auth, running_app


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app() as running:
        await running.identified()
        yield running


async def send(api: Api, body: dict[str, Any], ident: str = "sim.1", **params: Any) -> Any:
    return await api.client.post(f"/controllers/{ident}/commands", json=body, params=params)


async def test_a_setting_goes_out_and_its_query_reads_it_back(api: Api) -> None:
    mark = api.mark()
    r = await send(api, {"command": "OH{hs}", "hs": 4000})
    assert r.status_code == 200, r.text
    reply = r.json()
    assert reply["outcome"] == "done"
    assert reply["frames"] == ["$1OH4000"]
    assert reply["results"][0] | {"attempts": 1} == reply["results"][0]
    assert reply["results"][0]["reply"] == "accepted"
    assert reply["results"][0]["value"] is None
    assert "OH4000" in api.heard(since=mark)
    r = await send(api, {"command": "OH"})
    assert r.json()["results"][0]["value"] == 4000
    assert r.json()["results"][0]["reply_format"] == "dec5"


# The factory settings of §16 (and §10 defaults) as each reply format decodes them.
FAMILIES = [
    ({"command": "OH"}, 5000),  # dec5, §16 OH 5000
    ({"command": "OL"}, 500),
    ({"command": "OS"}, 300),
    ({"command": "OX"}, 300),
    ({"command": "OC"}, 0),  # dec3
    ({"command": "PB"}, 10),  # dec3, §16 PB 10
    ({"command": "PA"}, 1),  # digit
    ({"command": "E"}, 0),  # digit: mode 0
    ({"command": "EP"}, 0),
    ({"command": "ED"}, 1),
    ({"command": "QE"}, 4),
    ({"command": "QD"}, 400),  # §16 Q 400
    ({"command": "GA"}, 0),
    ({"command": "N"}, 0),
    ({"command": "9{bit}", "bit": 4}, 0),  # condition bit 4: the mode
    ({"command": "6{mt}", "mt": 1}, 0),  # position
    ({"command": "2D"}, 0),
    ({"command": "A{pn}D", "pn": 5}, 0),
    ({"command": "QS"}, {"motor1": 0, "motor2": 0}),  # motor pair
    ({"command": "K"}, {"watch": 0, "outputs": {"value": 0, "hex": "00", "on": []}}),
    ({"command": "N{pn}", "pn": 1}, {"speed": 0, "remaining": 0}),  # speed point
    (
        {"command": "EA"},
        {"step_out_sensor": "A", "limit": "A", "org": "A", "emergency_stop": "A", "inp": "A"},
    ),
    ({"command": "C"}, {"value": 0, "hex": "00", "on": []}),  # inputs
    ({"command": "CO"}, {"value": 0, "hex": "00", "on": []}),  # outputs
    (
        {"command": "COA"},
        {"clr1": False, "clr2": False, "outputs": {"value": 0, "hex": "00", "on": []}},
    ),
    (
        {"command": "CA"},
        {"inp1": False, "inp2": False, "inputs": {"value": 0, "hex": "00", "on": []}},
    ),
    ({"command": "GR{bf}", "bf": "C"}, {"value": 0, "hex": "00", "on": []}),  # buffer
    ({"command": "GR{ct}", "ct": 2}, 0),
    ({"command": "GSS"}, "0"),  # program state: ended (none run)
    ({"command": "GN"}, 0),
]


@pytest.mark.parametrize(("body", "expected"), FAMILIES, ids=[b["command"] for b, _ in FAMILIES])
async def test_every_family_answers_its_decoded_reply(
    api: Api, body: dict[str, Any], expected: Any
) -> None:
    r = await send(api, body)
    assert r.status_code == 200, r.text
    result = r.json()["results"][0]
    assert result["reply"] == "data"
    assert result["value"] == expected


async def test_status_condition_sensors_and_version(api: Api) -> None:
    status = (await send(api, {"command": '""'})).json()["results"][0]
    assert status["reply_format"] == "status"
    assert status["value"]["moving"] is False
    condition = (await send(api, {"command": "9"})).json()["results"][0]["value"]
    assert condition["mode"] == 0 and condition["selected_motor"] in (1, 2)
    sensors = (await send(api, {"command": "CLM{mt}", "mt": 1})).json()["results"][0]["value"]
    # Position 0 lies between the scene's limit sensors (-5,000 and 95,000 pulses).
    assert sensors["cw_limit"] is False and sensors["ccw_limit"] is False
    version = (await send(api, {"command": "V"})).json()["results"][0]["value"]
    assert re.fullmatch(r"\d\.\d\d", version["version"])


async def test_motor_parameter_selects_the_motor_first(api: Api) -> None:
    r = await send(api, {"command": "OH{hs}", "hs": 3000}, motor=2)
    assert r.status_code == 200, r.text
    assert "F2" in api.heard() and "OH3000" in api.heard()
    assert (await send(api, {"command": "OH"}, motor=2)).json()["results"][0]["value"] == 3000
    assert (await send(api, {"command": "OH"}, motor=1)).json()["results"][0]["value"] == 5000


async def test_bad_bodies_are_422_naming_the_field_and_nothing_is_sent(api: Api) -> None:
    mark = api.mark()
    r = await send(api, {"command": "OH{hs}", "hs": 20000})
    assert r.status_code == 422
    assert r.headers["content-type"].startswith("application/problem+json")
    assert r.json()["field"] == "body.OH{hs}.hs"
    r = await send(api, {"command": "OH{hs}", "hs": 100, "speed": 1})
    assert r.status_code == 422 and r.json()["field"] == "body.OH{hs}.speed"
    r = await send(api, {"command": "NOPE"})
    assert r.status_code == 422 and r.json()["field"] == "body.command"  # the union's tag
    r = await send(api, {"command": "I"})  # opens program reception: never this way
    assert r.status_code == 422 and "PUT /controllers/{id}/program" in r.json()["rule"]
    r = await send(api, {"command": "/END"})  # a user-program statement, not a host command
    assert r.status_code == 422
    heard = api.heard(since=mark)
    assert not any(t.startswith(("OH2", "OH1", "I", "END")) for t in heard), heard


async def test_unknown_controller_is_404(api: Api) -> None:
    r = await send(api, {"command": "OH"}, ident="sim.9")
    assert r.status_code == 404
    assert "sim.9" in r.json()["detail"]


async def test_a_form_of_another_mode_is_refused_before_the_wire(api: Api) -> None:
    mark = api.mark()
    r = await send(api, {"command": "DS"})  # §10 DS: mode 2 only; the controller is in mode 0
    assert r.status_code == 422
    assert r.json()["field"] == "command"
    assert "modes 2 only" in r.json()["rule"]
    assert "DS" not in api.heard(since=mark)


async def test_settings_refused_while_moving_and_stop_always_goes(api: Api) -> None:
    # A move of 60,000 pulses (12 s at OH): 7/8 are refused on axes with soft limits
    assert (await send(api, {"command": "2{pp}", "pp": 60_000})).status_code == 200
    r = await send(api, {"command": "3{mt}", "mt": 1})
    assert r.status_code == 200, r.text
    await api.until(lambda: api.cached().moving)
    mark = api.mark()
    r = await send(api, {"command": "OC{dt}", "dt": 50})  # §10 OC: not while moving
    assert r.status_code == 409
    assert "§10 OC" in r.json()["detail"]
    assert "OC50" not in api.heard(since=mark)
    # OH may change while moving (§10 OH 動作中 ○)
    assert (await send(api, {"command": "OH{hs}", "hs": 4500})).status_code == 200
    api.leases.acquire("sim.1", "someone-else", 60)
    r = await send(api, {"command": "OH{hs}", "hs": 4600})
    assert r.status_code == 409 and r.json()["holder"] == "someone-else"
    r = await send(api, {"command": "S"})  # a stop is never refused, not even by a lease
    assert r.status_code == 200 and r.json()["frames"] == ["$1S"]
    await api.until(lambda: not api.cached().moving)


async def test_queries_need_no_lease(api: Api) -> None:
    api.leases.acquire("sim.1.2", "someone-else", 60)
    assert (await send(api, {"command": "OH"})).status_code == 200
    r = await send(api, {"command": "A{pn}{pp}", "pn": 1, "pp": 10})
    assert r.status_code == 409 and r.json()["holder"] == "someone-else"


async def test_roles_of_commands() -> None:
    async with running_app(roles=True) as api:
        url = "/controllers/sim.1/commands"
        mark = api.mark()
        r = await api.client.post(url, json={"command": "OH"}, headers=auth(Role.VIEWER))
        assert r.status_code == 403
        op = auth(Role.OPERATOR)
        assert (await api.client.post(url, json={"command": "OH"}, headers=op)).status_code == 200
        for body in ({"command": "DW"}, {"command": "E{mode}", "mode": 1}, {"command": "SUM1"}):
            r = await api.client.post(url, json=body, headers=op)
            assert r.status_code == 403, body
            assert r.json()["required_role"] == "admin"
        assert (await api.client.post(url, json={"command": "E"}, headers=op)).status_code == 200
        heard = api.heard(since=mark)
        assert "DW" not in heard and "E1" not in heard and "SUM1" not in heard
        admin = auth(Role.ADMIN)
        r = await api.client.post(url, json={"command": "DW"}, headers=admin)
        assert r.status_code == 200 and r.json()["outcome"] == "done"


async def test_the_body_is_documented_as_a_discriminated_union(api: Api) -> None:
    schema = api.app.openapi()
    operation = schema["paths"]["/api/v1/controllers/{id}/commands"]["post"]
    body = operation["requestBody"]["content"]["application/json"]["schema"]
    assert body["discriminator"]["propertyName"] == "command"
    mapping = body["discriminator"]["mapping"]
    assert {"OH{hs}", '""', "A{pn}{pp}", "GES", "EE///"} <= set(mapping)
    assert not any(key.startswith("/") for key in mapping)  # program statements are not host
    assert "admin" in operation["description"]
