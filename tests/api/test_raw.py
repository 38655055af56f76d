"""POST /loops/{loop}/raw: command text parsed through the catalog first."""

from __future__ import annotations

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


async def raw(api: Api, text: str, controller: str = "1", loop: str = "sim") -> Any:
    body = {"controller": controller, "text": text}
    return await api.client.post(f"/loops/{loop}/raw", json=body)


async def test_text_is_parsed_sent_and_answered_like_commands(api: Api) -> None:
    mark = api.mark()
    r = await raw(api, "OH4000")
    assert r.status_code == 200, r.text
    assert r.json()["frames"] == ["$1OH4000"]
    assert r.json()["results"][0]["form"] == "OH{hs}"
    assert "OH4000" in api.heard(since=mark)
    r = await raw(api, "OH")
    assert r.json()["results"][0]["value"] == 4000


async def test_the_controller_by_body_id_or_name(api: Api) -> None:
    mark = api.mark()
    assert (await raw(api, "OL600", controller="head")).status_code == 200  # body 2
    assert (await raw(api, "OL700", controller="sim.3")).status_code == 200
    assert "OL600" in api.heard("2", since=mark)
    assert "OL700" in api.heard("3", since=mark)
    assert (await raw(api, "OL", controller="7")).status_code == 404
    assert (await raw(api, "OL", loop="nowhere")).status_code == 404


@pytest.mark.parametrize(
    ("text", "field", "rule"),
    [
        ("OH4x00", "text", "forms of OH: OH{hs}, OH, OHI{id}, OHD{dd}"),
        ("OH20000", "text.hs", "hs: decimal 1-16383, up to 5 digits"),  # §10 OH
        ("XYZ", "text", "a command of the manual"),
        ("END", "text", "only inside a user program"),
        ("A12", "text.pn", None),  # position numbers are exactly 3 digits (§10 A)
        ("OH4000\r$1OH1", "text", None),  # one command a request: no CR, no '$'
        ("I", "text", None),  # never through raw: PUT /controllers/{id}/program
    ],
)
async def test_text_that_fits_no_form_is_refused_with_the_reason(
    api: Api, text: str, field: str, rule: str | None
) -> None:
    mark = api.mark()
    r = await raw(api, text)
    assert r.status_code == 422, r.text
    problem = r.json()
    assert problem["field"] == field
    assert problem["rule"]
    if rule is not None:
        assert problem["rule"] == rule
    heard = api.heard(since=mark)
    assert text not in heard and "OH1" not in heard and "I" not in heard


async def test_raw_is_for_admins_only() -> None:
    async with running_app(roles=True) as api:
        body = {"controller": "1", "text": "V"}
        for role in (Role.VIEWER, Role.OPERATOR):
            r = await api.client.post("/loops/sim/raw", json=body, headers=auth(role))
            assert r.status_code == 403
        r = await api.client.post("/loops/sim/raw", json=body, headers=auth(Role.ADMIN))
        assert r.status_code == 200
        assert r.json()["results"][0]["reply_format"] == "version"


async def test_raw_keeps_the_manual_rules_and_leases(api: Api) -> None:
    api.leases.acquire("sim.1", "someone-else", 60)
    r = await raw(api, "OH4000")
    assert r.status_code == 409 and r.json()["holder"] == "someone-else"
    assert (await raw(api, "OH")).status_code == 200
    r = await raw(api, "DS")  # §10 DS: mode 2 only (a query: no lease needed)
    assert r.status_code == 422 and "modes 2 only" in r.json()["rule"]


async def test_a_baud_rate_change_is_refused_and_the_controller_keeps_answering(api: Api) -> None:
    # ES1 would move controller 1 to 1200 bps while the loop runs at 9600 (§10 ES): the
    # gateway would lose it. The loop's rate is configuration.
    mark = api.mark()
    for r in (
        await raw(api, "ES1"),
        await api.client.post("/controllers/sim.1/commands", json={"command": "ES{bp}", "bp": 1}),
    ):
        assert r.status_code == 422, r.text
        assert "loops[].baud" in r.json()["rule"]
    assert not [t for t in api.heard(since=mark) if t.startswith("ES")]
    assert (await raw(api, "OH")).json()["results"][0]["value"] == 5000
