"""openapi/openapi.json read by the tools integrators use.

`openapi-spec-validator` accepts it; `openapi-python-client` generates a client whose names
read as verbs (`move_axis`, `home_axis`) and that homes and moves an axis of a running
`serve --simulate`, a retried move with the same `Idempotency-Key` getting the first answer.
"""

from __future__ import annotations

import importlib
import json
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from openapi_spec_validator import validate

from tests.support.serve_process import serve

OPENAPI = Path(__file__).parents[2] / "openapi" / "openapi.json"
DOCUMENT: dict[str, Any] = json.loads(OPENAPI.read_text(encoding="utf-8"))
VERBS = {
    "list", "get", "check", "set", "send", "take", "release", "move", "home", "jog", "step",
    "stop", "acknowledge", "erase", "load", "save", "pulse", "upload", "pause", "resume", "run",
}  # fmt: skip


def _operations() -> list[tuple[str, str, dict[str, Any]]]:
    return [
        (path, method, op)
        for path, item in DOCUMENT["paths"].items()
        for method, op in item.items()
        if isinstance(op, dict)
    ]


def test_the_document_is_valid_openapi() -> None:
    validate(DOCUMENT)


def test_operation_ids_read_as_verbs_on_their_resource() -> None:
    ids = {(method, path): op["operationId"] for path, method, op in _operations()}
    assert len(set(ids.values())) == len(ids)
    for (method, path), ident in ids.items():
        assert re.fullmatch(r"[a-z]+(?:[A-Z][a-z0-9]*)*", ident), (method, path, ident)
        assert re.match(r"[a-z]+", ident).group() in VERBS, (method, path, ident)  # type: ignore[union-attr]
    assert ids[("post", "/api/v1/axes/{id}/move")] == "moveAxis"
    assert ids[("post", "/api/v1/axes/{id}/home")] == "homeAxis"
    assert ids[("get", "/api/v1/operations/{id}")] == "getOperation"
    assert ids[("post", "/api/v1/controllers/{id}/lease")] == "takeControllerLease"


def test_tags_by_resource_keep_health_apart_from_motion_operations() -> None:
    tags = {(method, path): op["tags"] for path, method, op in _operations()}
    assert tags[("get", "/healthz")] == tags[("get", "/readyz")] == ["health"]
    assert tags[("get", "/metrics")] == ["metrics"]
    assert tags[("get", "/api/v1/operations/{id}")] == ["operations"]
    assert tags[("post", "/api/v1/axes/{id}/lease")] == ["leases"]
    assert tags[("post", "/api/v1/controllers/{id}/program/run")] == ["programs"]
    declared = {tag["name"] for tag in DOCUMENT["tags"]}
    assert {t for ts in tags.values() for t in ts} == declared


def test_every_post_declares_the_idempotency_key_header() -> None:
    posts = [(path, op) for path, method, op in _operations() if method == "post"]
    assert len(posts) > 15
    for path, op in posts:
        headers = [p for p in op["parameters"] if p["in"] == "header"]
        assert [h["name"] for h in headers] == ["Idempotency-Key"], path
        assert headers[0]["required"] is False


def _enums(node: Any) -> list[dict[str, Any]]:
    if isinstance(node, dict):
        found = [node] if "enum" in node else []
        return found + [e for value in node.values() for e in _enums(value)]
    if isinstance(node, list):
        return [e for item in node for e in _enums(item)]
    return []


def test_enum_members_have_names() -> None:
    enums = _enums(DOCUMENT)
    assert len(enums) > 50
    for schema in enums:
        names = schema["x-enum-varnames"]
        assert len(names) == len(schema["enum"]) == len(set(names)), schema
        assert all(re.fullmatch(r"[A-Z_][A-Z0-9_]*", n) for n in names), schema
    schemas = DOCUMENT["components"]["schemas"]
    # Python enums keep their member names; the others are made from the values.
    assert schemas["HomeMethod"]["x-enum-varnames"][:2] == ["SEARCH_1", "HIGH_2"]
    assert schemas["Cmd_B_dir"]["properties"]["dir"]["x-enum-varnames"] == ["PLUS", "MINUS"]


def test_no_open_schemas_where_the_shape_is_known() -> None:
    schemas = DOCUMENT["components"]["schemas"]
    request = schemas["OperationView"]["properties"]["request"]
    assert sorted(r["$ref"].rsplit("/", 1)[1] for r in request["anyOf"]) == [
        "HomeAsked", "JogAsked", "MoveAsked", "StepAsked",
    ]  # fmt: skip
    value = schemas["CommandView"]["properties"]["value"]
    assert {s.get("type") for s in value["anyOf"]} == {
        "null", "integer", "string", "boolean", "object",
    }  # fmt: skip
    counters = schemas["CountersSnapshot"]["properties"]
    assert counters["retries"]["type"] == counters["timeouts"]["type"] == "integer"
    assert counters["busy_time"]["type"] == "number"


@pytest.fixture(scope="module")
def generated_client(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The client openapi-python-client generates from openapi.json (package ``rc233_client``)."""
    out = tmp_path_factory.mktemp("client")
    bin_dir = Path(sys.executable).parent
    generator = bin_dir / "openapi-python-client"
    assert generator.exists(), "openapi-python-client is missing: `make test` installs it"
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}"}
    done = subprocess.run(
        [str(generator), "generate", "--path", str(OPENAPI), "--meta", "none",
         "--output-path", str(out / "rc233_client")],
        capture_output=True, text=True, env=env, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    return out


async def test_a_generated_client_homes_and_moves_an_axis(
    generated_client: Path, tmp_path: Path
) -> None:
    sys.path.insert(0, str(generated_client))
    try:
        client_mod = importlib.import_module("rc233_client")
        home_axis = importlib.import_module("rc233_client.api.axes.home_axis")
        move_axis = importlib.import_module("rc233_client.api.axes.move_axis")
        models = importlib.import_module("rc233_client.models")
    finally:
        sys.path.remove(str(generated_client))
    async with serve(tmp_path) as server:
        client = client_mod.AuthenticatedClient(base_url=server.url, token="unused", timeout=60)
        async with client as c:
            home = await home_axis.asyncio_detailed(
                "x", client=c, body=models.HomeRequest(method=models.HomeMethod.SEARCH_1),
                wait=True, timeout=30,
            )  # fmt: skip
            assert home.status_code == 200, home.content
            assert home.parsed.state == models.OperationState.DONE
            body = models.MoveRequest(position=12.5, unit=models.Unit.USER)
            move = await move_axis.asyncio_detailed(
                "x", client=c, body=body, wait=True, timeout=30, idempotency_key="mes-0001"
            )
            assert move.status_code == 200, move.content
            assert move.parsed.state == models.OperationState.DONE
            assert (move.parsed.position, move.parsed.position_user) == (1250, 12.5)
            assert move.parsed.request.position == 12.5  # typed: MoveAsked
            again = await move_axis.asyncio_detailed(
                "x", client=c, body=body, wait=True, timeout=30, idempotency_key="mes-0001"
            )
            assert again.headers["Idempotent-Replayed"] == "true"
            assert again.parsed.id == move.parsed.id
