"""The API boundary refuses what it cannot mean, before anything reaches the wire.

A hostile client's requests against the real app on a simulated loop: wrong JSON types,
NaN and infinities, bodies that are not UTF-8 or not JSON or nested too deep, no
Content-Type, bodies over the limit. Each answer is a 4xx problem naming the field and the
rule, and the simulated controller hears nothing of it.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import httpx
import pytest

from gateway.api.middleware.body_gate import BODY_LIMIT, MAX_DEPTH, check_json
from tests.support.sim_app import Api, running_app

PROBLEM = "application/problem+json"
JSON = {"Content-Type": "application/json"}


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    """The app with its poller stopped: whatever the line hears then, a request sent it."""
    async with running_app(("1", "2")) as api:
        await api.runtime.pollers["sim"].stop()
        # A read queues behind the poll the stop abandoned: once answered, the line is quiet.
        assert (await api.client.get("/axes/sim.2.1?fresh=true")).status_code == 200
        yield api


def problem_of(response: httpx.Response, status: int) -> dict[str, Any]:
    assert response.status_code == status, response.text
    assert response.headers["content-type"] == PROBLEM, response.headers
    body: dict[str, Any] = response.json()
    assert body["status"] == status
    assert body["type"].startswith("urn:rc233-gateway:problem:"), body
    return body


async def post_raw(api: Api, path: str, content: bytes, headers: dict[str, str] | None = None):
    return await api.client.post(
        path, content=content, headers=JSON if headers is None else headers
    )


def motion_heard(api: Api, since: int) -> list[str]:
    """Everything the controllers heard since ``since`` (the poller is stopped)."""
    return [text for body in api.bodies for text in api.heard(body, since)]


@pytest.mark.parametrize(
    ("body", "field"),
    [
        (b'{"position": true, "relative": true}', "body.position"),
        (b'{"position": "5", "relative": true}', "body.position"),
        (b'{"position": 5, "relative": 1}', "body.relative"),
        (b'{"position": 5, "relative": "true"}', "body.relative"),
    ],
)
async def test_a_wrong_json_type_is_refused_and_nothing_moves(api: Api, body: bytes, field: str):
    mark = api.mark()
    problem = problem_of(await post_raw(api, "/axes/sim.1.1/move", body), 422)
    assert problem["field"] == field
    assert motion_heard(api, mark) == []
    assert api.position("1", 1) == 0


async def test_the_openapi_document_says_the_strict_types(api: Api):
    schema = (await api.client.get("/openapi.json")).json()["components"]["schemas"]
    move = schema["MoveRequest"]["properties"]
    assert move["position"]["type"] == "number"
    assert move["relative"]["type"] == "boolean"


@pytest.mark.parametrize("token", [b"-Infinity", b"Infinity", b"NaN", b"1e400", b"-1e999"])
async def test_nan_and_infinity_are_refused_naming_the_field(api: Api, token: bytes):
    mark = api.mark()
    body = b'{"position": ' + token + b', "unit": "user"}'
    problem = problem_of(await post_raw(api, "/axes/sim.2.1/move", body), 422)
    assert problem["field"] == "body.position"
    assert "finite" in problem["rule"]
    assert motion_heard(api, mark) == []


async def test_a_huge_integer_is_refused_naming_the_field(api: Api):
    body = b'{"position": 1' + b"0" * 5000 + b"}"
    problem = problem_of(await post_raw(api, "/axes/sim.1.1/move", body), 422)
    assert problem["field"] == "body.position"


async def test_a_lone_surrogate_is_refused_naming_the_field(api: Api):
    mark = api.mark()
    problem = problem_of(await post_raw(api, "/axes/sim.1.1/home", b'{"method": "\\ud800"}'), 422)
    assert problem["field"] == "body.method"
    assert "surrogate" in problem["rule"]
    assert motion_heard(api, mark) == []


async def test_a_body_that_is_not_utf8_names_the_body_and_the_byte(api: Api):
    problem = problem_of(await post_raw(api, "/axes/sim.1.1/home", b'{"unit": "\xff\xfe"}'), 422)
    assert problem["field"] == "body"
    assert "UTF-8" in problem["rule"]
    assert "byte 10" in problem["detail"]


async def test_deep_nesting_is_refused_without_parsing_it(api: Api):
    body = b"[" * 5000 + b"]" * 5000
    problem = problem_of(await post_raw(api, "/axes/sim.1.1/move", body), 422)
    assert problem["field"] == "body"
    assert str(MAX_DEPTH) in problem["rule"]


async def test_malformed_json_names_line_and_column_not_an_offset(api: Api):
    problem = problem_of(await post_raw(api, "/axes/sim.1.1/move", b'{"position":\n 5,,}'), 422)
    assert problem["field"] == "body"
    assert "line 2 column 4" in problem["detail"]


async def test_a_body_without_content_type_is_415_naming_the_header(api: Api):
    response = await api.client.post(
        "/axes/sim.1.1/move", content=b'{"position": 5}', headers={"Content-Type": ""}
    )
    problem = problem_of(response, 415)
    assert problem["field"] == "header.content-type"
    assert "application/json" in problem["rule"]


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "NaN"])
async def test_a_query_nan_is_refused_as_not_finite(api: Api, value: str):
    mark = api.mark()
    response = await api.client.post(
        f"/axes/sim.1.1/move?wait=true&timeout={value}", json={"position": 5}
    )
    problem = problem_of(response, 422)
    assert problem["field"] == "query.timeout"
    assert "finite" in problem["rule"]
    assert motion_heard(api, mark) == []


async def test_a_nan_lease_ttl_is_refused_as_not_finite(api: Api):
    problem = problem_of(await post_raw(api, "/axes/sim.1.1/lease", b'{"ttl": NaN}'), 422)
    assert problem["field"] == "body.ttl"
    assert "finite" in problem["rule"]


async def test_a_body_over_the_limit_is_413_before_it_is_read(api: Api):
    read = 0

    async def chunks() -> AsyncIterator[bytes]:
        nonlocal read
        for _ in range(10 * 1024):  # 10 MiB in 1 KiB chunks, counted as they are taken
            read += 1024
            yield b" " * 1024

    response = await api.client.post("/axes/sim.1.1/move", content=chunks(), headers=JSON)
    problem = problem_of(response, 413)
    assert problem["field"] == "body"
    assert str(BODY_LIMIT) in problem["rule"]
    assert read <= BODY_LIMIT + 2 * 1024


async def test_a_declared_length_over_the_limit_is_413_at_once(api: Api):
    response = await api.client.post(
        "/axes/sim.1.1/move",
        content=b"{}",
        headers={**JSON, "Content-Length": str(10 * 1024 * 1024)},
    )
    problem_of(response, 413)


@pytest.mark.parametrize("unit", ["pulse", "user"])
async def test_a_huge_finite_target_is_refused_before_anything_is_read(api: Api, unit: str):
    mark = api.mark()
    body = b'{"position": -1e308, "unit": "' + unit.encode() + b'"}'
    problem = problem_of(await post_raw(api, "/axes/sim.2.1/move", body), 422)
    assert problem["field"] == "body.position"
    assert list(api.sim.log.since(mark)) == []  # not even the EP read of the management


async def test_the_document_lists_413_and_415_on_operations_with_a_body(api: Api):
    paths = (await api.client.get("/openapi.json")).json()["paths"]
    move = paths["/api/v1/axes/{id}/move"]["post"]["responses"]
    assert PROBLEM in move["413"]["content"] and PROBLEM in move["415"]["content"]
    assert str(BODY_LIMIT) in move["413"]["description"]
    assert "413" not in paths["/api/v1/axes"]["get"]["responses"]


@pytest.mark.parametrize(
    ("depth", "refused"), [(MAX_DEPTH, False), (MAX_DEPTH + 1, True), (200_000, True)]
)
def test_nesting_is_refused_just_past_the_limit_and_far_past_it(depth: int, refused: bool):
    refusal = check_json(b"[" * depth + b"]" * depth)
    assert (refusal is not None) is refused
    assert refusal is None or refusal.field == "body"


def test_a_surrogate_pair_is_text_and_an_escaped_backslash_is_not_a_surrogate():
    assert check_json(b'{"note": "\\ud83d\\ude00", "path": "C:\\\\ud800"}') is None
