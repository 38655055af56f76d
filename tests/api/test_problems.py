"""Every error as application/problem+json (RFC 9457), on a small app of the test's own."""

from __future__ import annotations

import logging
from typing import Any

import httpx
import pytest
from fastapi import FastAPI
from pydantic import BaseModel

from gateway.api.problem_docs import install_problem_docs
from gateway.api.problems import PROBLEM_RESPONSES, install_problem_handlers
from gateway.bus.requests import DeadlineExpired, LoopDown, TransactionError
from gateway.errors import (
    ConflictError,
    DeviceError,
    NotFoundError,
    ParameterError,
    ProgramError,
    ReplyFormatError,
)

PROBLEM = "application/problem+json"


class Move(BaseModel):
    position: int
    relative: bool = False


def build_app() -> FastAPI:
    app = FastAPI()
    install_problem_handlers(app)
    install_problem_docs(app)

    @app.post("/axes/{ident}/move", responses=PROBLEM_RESPONSES)
    async def move(ident: str, body: Move) -> dict[str, Any]:
        return {"ident": ident, "position": body.position}

    raising: dict[str, Exception] = {
        "parameter": ParameterError(
            "OH 70000 is out of range", field="speed", rule="1 to 65535 pps (§10 OH)"
        ),
        "program": ProgramError("unknown statement", step=3, field="program", rule="§11-3"),
        "not-found": NotFoundError("axis", "main.9.1", known=("main.1.1",)),
        "leased": ConflictError("axis x is leased", field="axis", holder="alice"),
        "moving": ConflictError("axis x is moving", field="axis"),
        "timeout": DeviceError("no reply to M", outcome="unknown", timeout=True),
        "down": LoopDown("main", "port gone", retry_after=2.2),
        "down-soon": LoopDown("main", "port gone", retry_after=0.01),
        "down-closed": LoopDown("main", "the scheduler was closed"),
        "down-in-flight": LoopDown("main", "port gone", retry_after=1.0, in_flight=True),
        "deadline": DeadlineExpired("main", "1", 30.0, 12),
        "transaction": TransactionError("body number 'Z' is not one of 0-E (§9-1)"),
        "reply": ReplyFormatError("9 reply 'xyz' is not 8 binary digits"),
        "bug": RuntimeError("secret internals: password=hunter2"),
    }

    @app.get("/raise/{kind}")
    async def fail(kind: str) -> None:
        raise raising[kind]

    return app


@pytest.fixture
async def client() -> Any:
    transport = httpx.ASGITransport(app=build_app())
    async with httpx.AsyncClient(transport=transport, base_url="http://localhost") as c:
        yield c


def problem_of(response: httpx.Response, status: int) -> dict[str, Any]:
    assert response.status_code == status, response.text
    assert response.headers["content-type"] == PROBLEM
    body: dict[str, Any] = response.json()
    assert body["status"] == status
    assert body["title"]
    return body


async def test_a_bad_field_names_the_field_the_rule_and_the_input(client: httpx.AsyncClient):
    r = await client.post("/axes/x/move", json={"position": "ten", "relative": False})
    body = problem_of(r, 422)
    assert body["field"] == "body.position"
    assert "integer" in body["rule"]
    assert body["detail"].startswith("body.position: ")
    assert body["errors"] == [{"field": "body.position", "rule": body["rule"], "input": "ten"}]
    assert body["instance"] == "/axes/x/move"


async def test_every_bad_field_is_listed_the_first_in_the_detail(client: httpx.AsyncClient):
    r = await client.post("/axes/x/move", json={"relative": "perhaps"})
    body = problem_of(r, 422)
    fields = [e["field"] for e in body["errors"]]
    assert fields == ["body.position", "body.relative"]
    assert body["errors"][0]["rule"] == "Field required"
    assert "input" not in body["errors"][0]  # a missing field has no input to show
    assert body["errors"][1]["input"] == "perhaps"
    assert body["detail"] == "body.position: Field required (and 1 more)"


async def test_text_that_is_not_json_is_a_422_problem(client: httpx.AsyncClient):
    r = await client.post(
        "/axes/x/move", content=b"{position: 1", headers={"content-type": "application/json"}
    )
    body = problem_of(r, 422)
    assert body["field"].startswith("body")


async def test_an_invalid_input_error_keeps_its_field_and_rule(client: httpx.AsyncClient):
    body = problem_of(await client.get("/raise/parameter"), 422)
    assert body["field"] == "speed"
    assert body["rule"] == "1 to 65535 pps (§10 OH)"
    assert body["detail"] == "OH 70000 is out of range"


async def test_a_program_error_names_its_step(client: httpx.AsyncClient):
    body = problem_of(await client.get("/raise/program"), 422)
    assert body["step"] == 3
    assert body["detail"] == "step 3: unknown statement"


async def test_unknown_id_is_404(client: httpx.AsyncClient):
    body = problem_of(await client.get("/raise/not-found"), 404)
    assert "main.9.1" in body["detail"]


async def test_a_lease_names_its_holder(client: httpx.AsyncClient):
    body = problem_of(await client.get("/raise/leased"), 409)
    assert body["holder"] == "alice"
    assert body["field"] == "axis"
    moving = problem_of(await client.get("/raise/moving"), 409)
    assert "holder" not in moving
    assert moving["type"] != body["type"]


async def test_no_answer_from_the_device_is_504_with_the_outcome(client: httpx.AsyncClient):
    body = problem_of(await client.get("/raise/timeout"), 504)
    assert body["outcome"] == "unknown"


@pytest.mark.parametrize(
    ("kind", "retry_after", "outcome"),
    [
        ("down", "3", "not_done"),  # 2.2 s rounded up
        ("down-soon", "1", "not_done"),  # never 0: at least one second
        ("down-closed", "5", "not_done"),  # no hint: the longest reconnect backoff
        ("down-in-flight", "1", "unknown"),  # sent commands may have acted
    ],
)
async def test_a_loop_down_is_503_with_retry_after(
    client: httpx.AsyncClient, kind: str, retry_after: str, outcome: str
):
    r = await client.get(f"/raise/{kind}")
    body = problem_of(r, 503)
    assert r.headers["retry-after"] == retry_after
    assert body["outcome"] == outcome
    assert "main" in body["detail"]


async def test_a_request_that_could_not_start_in_time_is_503(client: httpx.AsyncClient):
    r = await client.get("/raise/deadline")
    body = problem_of(r, 503)
    assert body["outcome"] == "not_done"
    assert r.headers["retry-after"] == "1"


async def test_a_request_the_scheduler_refuses_is_422(client: httpx.AsyncClient):
    body = problem_of(await client.get("/raise/transaction"), 422)
    assert "§9-1" in body["rule"]


async def test_a_bad_reply_from_the_device_is_502(client: httpx.AsyncClient):
    body = problem_of(await client.get("/raise/reply"), 502)
    assert "8 binary digits" in body["detail"]


async def test_unknown_path_and_wrong_method_are_problems(client: httpx.AsyncClient):
    missing = problem_of(await client.get("/nowhere"), 404)
    assert missing["type"] == "about:blank"
    assert missing["title"] == "Not Found"
    r = await client.delete("/axes/x/move")
    problem_of(r, 405)
    assert r.headers["allow"] == "POST"


async def test_a_bug_is_a_500_without_internals_and_is_logged(
    client: httpx.AsyncClient, caplog: pytest.LogCaptureFixture
):
    with caplog.at_level(logging.ERROR, logger="gateway.api"):
        r = await client.get("/raise/bug")
    body = problem_of(r, 500)
    assert "hunter2" not in r.text and "RuntimeError" not in r.text
    reference = body["detail"].rsplit(" ", 1)[-1]
    logged = [rec for rec in caplog.records if reference in rec.getMessage()]
    assert logged and logged[0].exc_info is not None
    assert "hunter2" in str(logged[0].exc_info[1])


def test_openapi_documents_errors_as_problems():
    doc = build_app().openapi()
    responses = doc["paths"]["/axes/{ident}/move"]["post"]["responses"]
    for status in ("404", "409", "422", "503", "504"):
        content = responses[status]["content"]
        assert list(content) == [PROBLEM], status
        assert content[PROBLEM]["schema"] == {"$ref": "#/components/schemas/Problem"}
    # FastAPI's own 422 of the route without PROBLEM_RESPONSES is rewritten too.
    fail = doc["paths"]["/raise/{kind}"]["get"]["responses"]["422"]["content"]
    assert list(fail) == [PROBLEM]
    schemas = doc["components"]["schemas"]
    assert "HTTPValidationError" not in schemas and "ValidationError" not in schemas
    assert {"type", "title", "status", "detail", "field", "rule", "errors", "holder"} <= set(
        schemas["Problem"]["properties"]
    )
