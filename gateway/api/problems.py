"""Every error of the API as ``application/problem+json`` (RFC 9457), naming the field and rule.

``install_problem_handlers(app)`` maps the gateway's exceptions to problems:

=========================  ======  ==========================================================
exception                  status  what the body adds
=========================  ======  ==========================================================
RequestValidationError     422     ``errors`` [{field, rule, input}]; ``field``/``rule`` of
                                   the first; ``detail`` names it
InvalidInputError          422     ``field``, ``rule`` (``step`` for a ProgramError)
TransactionError           422     the scheduler refused the request before queueing it
NotFoundError              404     ``detail`` names the kind and the id
ConflictError              409     ``field``; ``holder`` when a lease is held by another client
DeviceError                504     ``outcome`` (``not_done`` / ``unknown``)
LoopDown                   503     ``Retry-After`` (integer seconds, >= 1); ``outcome``
DeadlineExpired            503     ``Retry-After: 1``; ``outcome`` ``not_done``
StateUnavailable           503     ``Retry-After: 5``; ``outcome`` ``not_done`` (not recorded)
ProtocolError              502     the device's bytes were not what the manual allows
Starlette HTTPException    its     404 / 405 (``Allow`` kept) / 401 ... as problems
anything else              500     no internals: a reference to find the traceback in the log
=========================  ======  ==========================================================

The anything-else case is a pure ASGI middleware inside the user middlewares (so the audit and
metrics middlewares, installed after it, see the 500), not Starlette's ``ServerErrorMiddleware``
handler, which re-raises to the server after answering.
"""

from __future__ import annotations

import json
import logging
import math
import uuid
from collections.abc import Mapping
from http import HTTPStatus
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel, ConfigDict
from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from gateway.api.service_fields import http_field
from gateway.errors import (
    ConflictError,
    DeviceError,
    InvalidInputError,
    NotFoundError,
    ProgramError,
    ProtocolError,
    StateUnavailable,
)
from gateway.service.runtime.bus_types import DeadlineExpired, LoopDown, TransactionError

__all__ = [
    "PROBLEM_MEDIA_TYPE",
    "PROBLEM_RESPONSES",
    "ApiProblem",
    "FieldProblem",
    "Problem",
    "install_problem_handlers",
    "problem_response",
    "problem_type",
]

log = logging.getLogger("gateway.api")

PROBLEM_MEDIA_TYPE = "application/problem+json"
#: Retry-After of a 503 when the scheduler gives no hint (a closed loop): its longest backoff
DEFAULT_RETRY_AFTER = 5


def problem_type(slug: str) -> str:
    """The ``type`` URI of one of the gateway's problems (a URN: there is no page to fetch)."""
    return f"urn:rc233-gateway:problem:{slug}"


class FieldProblem(BaseModel):
    """One input that breaks a rule: where it is, the rule, and what was given."""

    field: str | None = None
    rule: str
    input: Any = None


class Problem(BaseModel):
    """RFC 9457 problem details, with the gateway's extension members."""

    model_config = ConfigDict(extra="allow")

    type: str = "about:blank"
    title: str
    status: int
    detail: str | None = None
    instance: str | None = None
    #: the input the problem is about (``body.position``, ``path.id``)
    field: str | None = None
    #: the rule it breaks, in words (the manual's rule for device parameters)
    rule: str | None = None
    errors: list[FieldProblem] | None = None
    #: the client holding the lease that refused the request (409)
    holder: str | None = None
    #: whether the device acted: ``not_done`` (certainly not) or ``unknown`` (503, 504)
    outcome: str | None = None
    #: the role the request needs (403)
    required_role: str | None = None
    #: the loops that are down (503 of ``/readyz``)
    loops_down: list[str] | None = None
    #: the operation (an OperationView) a motion ended failed / unknown is about (409, 504 of
    #: a motion request with wait=true: gateway.api.motion_problems)
    operation: dict[str, Any] | None = None


def _documented(status: int) -> dict[str, Any]:
    return {
        "model": Problem,
        "description": HTTPStatus(status).phrase,
        "content": {PROBLEM_MEDIA_TYPE: {"schema": {"$ref": "#/components/schemas/Problem"}}},
    }


#: ``responses=`` of routes: every error status the API answers, documented as ``Problem``.
PROBLEM_RESPONSES: dict[int | str, dict[str, Any]] = {
    status: _documented(status) for status in (400, 401, 403, 404, 409, 422, 503, 504)
}


class ApiProblem(Exception):
    """Raise to answer with ``problem`` (and ``headers``) from anywhere in a request."""

    def __init__(self, problem: Problem, headers: Mapping[str, str] | None = None) -> None:
        super().__init__(problem.detail or problem.title)
        self.problem = problem
        self.headers = dict(headers or {})


class _ProblemJSON(JSONResponse):
    """JSON as Starlette writes it, or with ASCII escapes when UTF-8 cannot hold the text
    (a lone surrogate a client sent, echoed as ``input``): a refusal never becomes a 500."""

    media_type = PROBLEM_MEDIA_TYPE

    def render(self, content: Any) -> bytes:
        try:
            return super().render(content)
        except UnicodeEncodeError:
            return json.dumps(content, separators=(",", ":")).encode("ascii")


def problem_response(
    problem: Problem, request: Request | None = None, headers: Mapping[str, str] | None = None
) -> Response:
    """``problem`` as an ``application/problem+json`` response (``instance``: the path)."""
    if problem.instance is None and request is not None:
        problem = problem.model_copy(update={"instance": request.url.path})
    return _ProblemJSON(
        problem.model_dump(mode="json", exclude_none=True),
        status_code=problem.status,
        headers=dict(headers or {}),
        media_type=PROBLEM_MEDIA_TYPE,
    )


def _json_safe(value: Any) -> Any:
    try:
        return jsonable_encoder(value)
    except Exception:  # an input pydantic kept but JSON cannot hold
        return repr(value)


def _validation_problem(exc: RequestValidationError) -> Problem:
    entries: list[FieldProblem] = []
    for err in exc.errors():
        loc = tuple(err.get("loc", ()))
        if err.get("type") in ("union_tag_invalid", "union_tag_not_found"):
            # The union's tag is at fault: name it (body.command), not the whole body.
            loc += (str(err.get("ctx", {}).get("discriminator", "")).strip("'"),)
        field = ".".join(str(part) for part in loc if part != "") or None
        # For a missing field pydantic's input is the enclosing object: nothing to show.
        given = None if err.get("type") == "missing" else _json_safe(err.get("input"))
        entries.append(FieldProblem(field=field, rule=str(err.get("msg", "")), input=given))
    first = entries[0] if entries else FieldProblem(rule="the request is not valid")
    more = f" (and {len(entries) - 1} more)" if len(entries) > 1 else ""
    where = f"{first.field}: " if first.field else ""
    return Problem(
        type=problem_type("invalid-input"),
        title="Invalid input",
        status=422,
        detail=f"{where}{first.rule}{more}",
        field=first.field,
        rule=first.rule,
        errors=entries,
    )


def _retry_after(seconds: float | None) -> str:
    if seconds is None or not math.isfinite(seconds):
        return str(DEFAULT_RETRY_AFTER)
    return str(max(1, math.ceil(seconds)))


def _problem_for(exc: Exception) -> tuple[Problem, dict[str, str]] | None:
    """The problem of one of the gateway's exceptions; None for anything else."""
    if isinstance(exc, InvalidInputError):
        extra: dict[str, Any] = {"step": exc.step} if isinstance(exc, ProgramError) else {}
        problem = Problem(
            type=problem_type("invalid-input"),
            title="Invalid input",
            status=422,
            detail=str(exc),
            field=exc.field,
            rule=exc.rule,
            errors=[FieldProblem(field=exc.field, rule=exc.rule)],
            **extra,
        )
        return problem, {}
    if isinstance(exc, TransactionError):
        detail = str(exc)
        problem = Problem(
            type=problem_type("transaction-refused"),
            title="Request refused by the loop scheduler",
            status=422,
            detail=detail,
            rule=detail,
            outcome="not_done",
        )
        return problem, {}
    if isinstance(exc, NotFoundError):
        return Problem(
            type=problem_type("not-found"),
            title="Not found",
            status=404,
            detail=str(exc),
            field=exc.field,
            rule=f"a {exc.kind} of the configuration" if exc.field else None,
        ), {}
    if isinstance(exc, ConflictError):
        slug = "lease-held" if exc.holder is not None else "conflict"
        return Problem(
            type=problem_type(slug),
            title="Conflict",
            status=409,
            detail=str(exc),
            field=exc.field,
            holder=exc.holder,
            rule=exc.rule,
        ), {}
    if isinstance(exc, DeviceError):
        return Problem(
            type=problem_type("device-timeout" if exc.timeout else "device-error"),
            title="No answer from the device" if exc.timeout else "The device's answer is in doubt",
            status=504,
            detail=str(exc),
            outcome=exc.outcome,
        ), {}
    if isinstance(exc, LoopDown):
        # in_flight: commands already sent may have acted; otherwise nothing was sent.
        return Problem(
            type=problem_type("loop-down"),
            title="Loop down",
            status=503,
            detail=str(exc),
            outcome="unknown" if exc.in_flight else "not_done",
        ), {"Retry-After": _retry_after(exc.retry_after)}
    if isinstance(exc, StateUnavailable):
        return Problem(
            type=problem_type("state-unavailable"),
            title="The state store cannot record the request",
            status=503,
            detail=str(exc),
            outcome="not_done",
        ), {"Retry-After": "5"}
    if isinstance(exc, DeadlineExpired):
        return Problem(
            type=problem_type("deadline-expired"),
            title="The loop is too busy",
            status=503,
            detail=str(exc),
            outcome="not_done",
        ), {"Retry-After": "1"}
    if isinstance(exc, ProtocolError):
        return Problem(
            type=problem_type("device-protocol"),
            title="The device's reply is not what the manual allows",
            status=502,
            detail=str(exc),
            outcome="unknown",
        ), {}
    return None


def _internal(request_path: str | None, exc: BaseException) -> Problem:
    reference = uuid.uuid4().hex[:12]
    log.error("internal error %s on %s", reference, request_path, exc_info=exc)
    return Problem(
        type=problem_type("internal-error"),
        title="Internal server error",
        status=500,
        detail=f"the gateway failed; the server log has the details under reference {reference}",
        instance=request_path,
    )


async def _on_gateway_error(request: Request, exc: Exception) -> Response:
    if isinstance(exc, InvalidInputError | ConflictError):
        # the service names its own argument; the route knows the HTTP field it came from
        exc.field = http_field(request, exc, exc.field)
    mapped = _problem_for(exc)
    if mapped is None:
        return problem_response(_internal(request.url.path, exc), request)
    problem, headers = mapped
    return problem_response(problem, request, headers)


async def _on_validation(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, RequestValidationError)
    return problem_response(_validation_problem(exc), request)


async def _on_api_problem(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, ApiProblem)
    return problem_response(exc.problem, request, exc.headers)


async def _on_http(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, HTTPException)
    headers = dict(exc.headers or {})
    if exc.status_code in (204, 304) or exc.status_code < 200:
        return Response(status_code=exc.status_code, headers=headers)
    try:
        phrase = HTTPStatus(exc.status_code).phrase
    except ValueError:
        phrase = "Error"
    detail = exc.detail if isinstance(exc.detail, str) else str(jsonable_encoder(exc.detail))
    problem = Problem(
        title=phrase, status=exc.status_code, detail=None if detail == phrase else detail
    )
    return problem_response(problem, request, headers)


async def _on_unexpected(request: Request, exc: Exception) -> Response:
    # Last resort, in Starlette's ServerErrorMiddleware (an exception raised by a middleware).
    return problem_response(_internal(request.url.path, exc), request)


class _CatchAllMiddleware:
    """Answer any exception a route lets through with a 500 problem (logged, no internals)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = False

        async def tracking_send(message: Message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        try:
            await self.app(scope, receive, tracking_send)
        except Exception as exc:
            if started:  # too late for a problem: the server closes the connection
                raise
            response = problem_response(_internal(scope.get("path"), exc))
            await response(scope, receive, send)


def install_problem_handlers(app: FastAPI) -> None:
    """Answer every error of ``app`` as a problem (``problem_docs.install_problem_docs``, which
    ``openapi_docs.install_openapi_docs`` calls, documents them so in its OpenAPI: it reads the
    routes' roles from security, which stands on this module).

    Call it before ``install_audit`` and ``install_health_and_metrics`` so their middlewares sit
    outside the catch-all and see its 500.
    """
    app.add_exception_handler(RequestValidationError, _on_validation)
    app.add_exception_handler(ApiProblem, _on_api_problem)
    app.add_exception_handler(HTTPException, _on_http)
    for cls in (
        InvalidInputError,
        TransactionError,
        NotFoundError,
        ConflictError,
        DeviceError,
        LoopDown,
        DeadlineExpired,
        ProtocolError,
        StateUnavailable,
    ):
        app.add_exception_handler(cls, _on_gateway_error)
    app.add_exception_handler(Exception, _on_unexpected)
    app.add_middleware(_CatchAllMiddleware)
