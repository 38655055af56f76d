"""The OpenAPI side of the problems: every error response documented as ``Problem``.

FastAPI documents its own 422 as JSON ``HTTPValidationError``, which the app never sends
(``problems.install_problem_handlers`` answers ``application/problem+json``); an operation
with a body also answers 413 and 415 (the body gate). Schemathesis
checks the content type and schema of every response against the document, so the document
has to say what the app does: ``install_problem_docs(app)`` wraps ``app.openapi``.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from http import HTTPStatus
from typing import Any

from fastapi import FastAPI

from gateway.api.middleware.body_gate import BODY_LIMIT
from gateway.api.problems import PROBLEM_MEDIA_TYPE, Problem
from gateway.api.security import route_roles

__all__ = ["document_problems", "install_problem_docs"]

_PROBLEM_REF = {"$ref": "#/components/schemas/Problem"}
_AUTH_STATUSES = ("401", "403")
#: what the body gate answers for an operation that takes a body (gateway.api.middleware.body_gate)
_BODY_STATUSES = {
    "413": f"The body is over {BODY_LIMIT} bytes (refused before it is read)",
    "415": "The body is not declared application/json",
}

#: what the body gate answers a request that acts without declaring JSON, bodyless too
_ACTING = frozenset({"POST", "PUT", "PATCH", "DELETE"})
_UNDECLARED = "The request is not declared application/json (every POST, PUT and DELETE is)"
_THROTTLED = (
    "Too many wrong tokens from this address: retry after Retry-After seconds "
    "(gateway.api.auth_failures)"
)


def _is_error_status(status: str) -> bool:
    return status in ("default", "4XX", "5XX") or (status.isdigit() and int(status) >= 400)


def document_problems(schema: dict[str, Any], secured: Mapping[tuple[str, str], bool]) -> None:
    """Rewrite an OpenAPI document so that every error response is ``Problem`` as
    ``application/problem+json`` (FastAPI documents its own 422 as JSON
    ``HTTPValidationError``), and secured operations (``secured[(path, method)]``) list 401
    and 403. Idempotent."""
    components = schema.setdefault("components", {}).setdefault("schemas", {})
    if "Problem" not in components:
        model = Problem.model_json_schema(ref_template="#/components/schemas/{model}")
        components.update(model.pop("$defs", {}))
        components["Problem"] = model
    content = {PROBLEM_MEDIA_TYPE: {"schema": dict(_PROBLEM_REF)}}
    for path, item in schema.get("paths", {}).items():
        for method, operation in item.items():
            if not isinstance(operation, dict) or "responses" not in operation:
                continue
            responses: dict[str, Any] = operation["responses"]
            if secured.get((path, method.upper())):
                for status in _AUTH_STATUSES:
                    responses.setdefault(status, {"description": HTTPStatus(int(status)).phrase})
                responses.setdefault("429", {"description": _THROTTLED})
            if "requestBody" in operation:
                for status, text in _BODY_STATUSES.items():
                    responses.setdefault(status, {"description": text})
            elif method.upper() in _ACTING:
                responses.setdefault("415", {"description": _UNDECLARED})
            for status, response in responses.items():
                if _is_error_status(str(status)) and isinstance(response, dict):
                    response["content"] = {k: dict(v) for k, v in content.items()}
    # FastAPI's own validation schemas, now unused (ValidationError only HTTPValidationError
    # refers to): dropped unless something else still refers to them.
    for name in ("HTTPValidationError", "ValidationError"):
        if name in components and f'"#/components/schemas/{name}"' not in json.dumps(schema):
            del components[name]


def install_problem_docs(app: FastAPI) -> None:
    """Make ``app.openapi()`` document every error as ``Problem`` (``document_problems``)."""
    original = app.openapi

    def openapi() -> dict[str, Any]:
        schema = original()
        secured = {
            (r.path, method): r.role is not None for r in route_roles(app) for method in r.methods
        }
        document_problems(schema, secured)
        return schema

    app.openapi = openapi  # type: ignore[method-assign]
