"""The boundary, swept: every field of every operation of openapi.json, given what it cannot mean.

Beside schemathesis (which generates requests from the document and checks the answers),
this sweep is exhaustive where schemathesis samples: for every operation, every field of its
JSON body (each variant of a union) and every query parameter, each of

* a value of the wrong JSON type, ``NaN``, ``Infinity``, ``-Infinity``, a huge number
  (``1e308``, and an integer of 31 digits), a lone surrogate (``"\\ud800"``), and a string
  longer than any field takes,

must be answered with a 4xx ``application/problem+json`` whose ``field`` (or one of its
``errors``) names that field; never a 5xx. Nothing reaches the wire: the loop's poller is
stopped for the sweep (after a read that queues behind its last poll), so the simulator's
line log must stay exactly as it was. Every mutating request is one line of the audit file,
in order.
"""

from __future__ import annotations

import json
from collections.abc import AsyncIterator, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from gateway.service.audit import AuditRecord
from tests.support.sim_app import Api, running_app

pytestmark = pytest.mark.contract

PROBLEM = "application/problem+json"
#: Stands in the body's JSON text for the bad value, replaced by the raw JSON of the value.
MARK = "@@bad-value@@"
LONG = "A" * 30_000

#: Raw JSON values that no field can mean, whatever its type (the wrong types come per type).
BAD_JSON = {
    "nan": "NaN",
    "infinity": "Infinity",
    "-infinity": "-Infinity",
    "huge": "1e308",
    "huge-integer": "1" + "0" * 30,
    "lone-surrogate": '"\\ud800"',
    "over-long": json.dumps(LONG),
}
WRONG_TYPE = {
    "number": ['"5"', "true"],
    "integer": ['"5"', "true", "5.5"],
    "boolean": ["1", '"true"'],
    "string": ["5", "true"],
    "array": ['"x"', "{}"],
    "object": ["[]", '"x"'],
}
BAD_QUERY = {
    "nan": "nan",
    "infinity": "inf",
    "-infinity": "-inf",
    "huge": "1e308",
    "huge-integer": "1" + "0" * 30,
    "lone-surrogate": "%ED%A0%80",
    "over-long": LONG,
}
WRONG_QUERY = {"number": ["five"], "integer": ["five", "5.5"], "boolean": ["maybe"]}
#: Path parameters: values that exist on the simulated loop (the field under test is elsewhere).
PATH_VALUES = {"loop": "sim", "bit": "0", "port": "inputs", "n": "1", "buffer": "A",
               "counter": "1", "motor": "1"}  # fmt: skip


@dataclass(frozen=True)
class Case:
    """One request: the operation, the field given a bad value, and how it is sent."""

    method: str
    path: str
    field: str  # body.position, query.timeout
    value: str  # the kind of bad value
    body: str | None  # JSON text, or None
    query: str  # raw query string

    def __str__(self) -> str:
        return f"{self.method} {self.path} {self.field}={self.value}"


class Schemas:
    """The document's schemas, with references resolved."""

    def __init__(self, document: dict[str, Any]) -> None:
        self.components = document["components"]["schemas"]

    def resolve(self, schema: dict[str, Any]) -> dict[str, Any]:
        while "$ref" in schema:
            schema = self.components[schema["$ref"].rsplit("/", 1)[1]]
        return schema

    def non_null(self, schema: dict[str, Any]) -> dict[str, Any]:
        """``schema`` without its ``null`` alternative (``X | None``)."""
        schema = self.resolve(schema)
        options = [s for s in schema.get("anyOf", []) if s.get("type") != "null"]
        return self.resolve(options[0]) if len(options) == 1 else schema

    def variants(self, schema: dict[str, Any]) -> list[dict[str, Any]]:
        """The object schemas a body may be (one, or each member of a union)."""
        schema = self.non_null(schema)
        return [self.resolve(s) for s in schema.get("oneOf", [])] or [schema]

    def kind(self, schema: dict[str, Any]) -> str:
        schema = self.non_null(schema)
        if "enum" in schema or "const" in schema:
            return "string" if isinstance((schema.get("enum") or [schema.get("const")])[0], str) \
                else "integer"  # fmt: skip
        return str(schema.get("type", "string"))

    def example(self, schema: dict[str, Any]) -> Any:
        """A plausible value for ``schema`` (the base the bad value is put into)."""
        schema = self.non_null(schema)
        if "const" in schema:
            return schema["const"]
        if "enum" in schema:
            return schema["enum"][0]
        if "default" in schema and schema["default"] is not None:
            return schema["default"]
        kind = schema.get("type")
        if kind in ("integer", "number"):
            return schema.get("minimum", 1)
        if kind == "boolean":
            return False
        if kind == "array":
            return []
        if kind == "object":
            return {}
        return "1"


def body_cases(schemas: Schemas, method: str, path: str, body: dict[str, Any]) -> Iterator[Case]:
    variants = schemas.variants(body)
    for variant in variants:
        properties: dict[str, Any] = variant.get("properties", {})
        required = set(variant.get("required", []))
        base = {
            name: schemas.example(prop)
            for name, prop in properties.items()
            if name in required or name == "command"
        }
        for name, prop in properties.items():
            if name == "command" and variant is not variants[0]:
                continue  # a union's tag is swept once, with its first member
            kind = schemas.kind(prop)
            text = json.dumps({**base, name: MARK})
            values = {f"wrong-type {v}": v for v in WRONG_TYPE.get(kind, [])} | BAD_JSON
            for label, raw in values.items():
                yield Case(method, path, f"body.{name}", label,
                           text.replace(json.dumps(MARK), raw), "")  # fmt: skip


def query_cases(
    schemas: Schemas, method: str, path: str, params: list[dict[str, Any]], body: str | None
) -> Iterator[Case]:
    for param in params:
        kind = schemas.kind(param["schema"])
        values = {f"wrong-type {v}": v for v in WRONG_QUERY.get(kind, [])} | BAD_QUERY
        for label, raw in values.items():
            query = f"{param['name']}={raw}"
            yield Case(method, path, f"query.{param['name']}", label, body, query)


def cases(document: dict[str, Any]) -> list[Case]:
    schemas = Schemas(document)
    found: list[Case] = []
    for template, operations in document["paths"].items():
        for method, operation in operations.items():
            path = template
            for param in operation.get("parameters", []):
                if param["in"] == "path":
                    name = param["name"]
                    value = PATH_VALUES.get(name)
                    if name == "id":
                        value = {"/api/v1/axes": "sim.1.1", "/api/v1/controllers": "sim.1",
                                 "/api/v1/operations": "op-0"}[template.rsplit("/{id}", 1)[0]
                                                               .split("/{")[0]]  # fmt: skip
                    path = path.replace("{" + name + "}", str(value))
            content = operation.get("requestBody", {}).get("content", {})
            body_schema = content.get("application/json", {}).get("schema")
            base_body = None
            if body_schema is not None:
                found += body_cases(schemas, method.upper(), path, body_schema)
                variant = schemas.variants(body_schema)[0]
                base_body = json.dumps(
                    {
                        name: schemas.example(prop)
                        for name, prop in variant.get("properties", {}).items()
                        if name in variant.get("required", []) or name == "command"
                    }
                )
            query = [p for p in operation.get("parameters", []) if p["in"] == "query"]
            found += query_cases(schemas, method.upper(), path, query, base_body)
    return found


@pytest.fixture
async def api(tmp_path: Path) -> AsyncIterator[Api]:
    async with running_app(("1", "2"), audit_log=tmp_path / "audit.jsonl") as api:
        await api.runtime.pollers["sim"].stop()
        # A read queues behind the poll the stop abandoned: once answered, the line is quiet.
        assert (await api.client.get("/axes/sim.1.1?fresh=true")).status_code == 200
        yield api


def names_field(problem: dict[str, Any], field: str) -> bool:
    """``problem`` names ``field`` (``body.hs`` is named by ``body.OH{hs}.hs`` too: a union
    member's errors carry its tag)."""
    named = [problem.get("field")] + [e.get("field") for e in problem.get("errors") or []]
    leaf = field.split(".", 1)[1]
    where = field.split(".", 1)[0]
    return any(
        isinstance(n, str)
        and (n == field or (n.startswith(where + ".") and n.endswith("." + leaf)))
        for n in named
    )


async def test_every_field_of_every_operation_refuses_what_it_cannot_mean(
    api: Api, tmp_path: Path
) -> None:
    document = (await api.client.get("/openapi.json")).json()
    sweep = cases(document)
    assert len(sweep) > 1000, "the sweep found too few fields to be the whole document"
    mark = api.mark()
    failures: list[str] = []
    for case in sweep:
        before = api.mark()
        url = case.path.removeprefix("/api/v1") + (f"?{case.query}" if case.query else "")
        headers = {"Content-Type": "application/json"} if case.body is not None else {}
        response = await api.client.request(
            case.method,
            url,
            content=case.body.encode("utf-8", "surrogatepass") if case.body else None,
            headers=headers,
        )
        if api.mark() != before:
            failures.append(
                f"{case}: on the wire: {[bytes(r.data) for r in api.sim.log.since(before)]}"
            )
        if not 400 <= response.status_code < 500:
            failures.append(f"{case}: {response.status_code} {response.text[:200]}")
        elif response.headers.get("content-type") != PROBLEM:
            failures.append(f"{case}: {response.headers.get('content-type')}")
        elif not names_field(response.json(), case.field):
            failures.append(f"{case}: names {response.json().get('field')!r} "
                            f"({response.json().get('detail', '')[:120]})")  # fmt: skip
    assert not failures, f"{len(failures)} of {len(sweep)}:\n" + "\n".join(failures[:60])
    heard = [(r.kind.name, r.body, bytes(r.data)) for r in api.sim.log.since(mark)]
    assert heard == [], f"the sweep put something on the wire: {heard}"
    audit: AuditRecord = api.services.audit
    await audit.flush()
    lines = (tmp_path / "audit.jsonl").read_text("utf-8").splitlines()
    assert [json.loads(line)["seq"] for line in lines] == list(range(1, audit.last_seq + 1))
    mutating = sum(1 for c in sweep if c.method in ("POST", "PUT", "PATCH", "DELETE"))
    outcomes = [e for e in map(json.loads, lines) if e.get("event") != "intent"]
    assert len(outcomes) == mutating  # and, for those who may act, one written ahead
