"""The audit log, to answer "who did this to the machine": every mutating request, in JSON lines.

``AuditMiddleware`` records every POST, PUT, PATCH and DELETE, refused ones too (401, 403,
422). A request that may act (an operator's or an admin's) has its entry written ahead,
before the route runs (``api.middleware.audit_ahead``; refused 503 with ``Retry-After`` when it
cannot be written), and a second entry once its response has started, naming the first
(``intent``). The second holds time (ISO 8601 UTC), token name and role, client address,
method, path, query, request body (JSON; longer than 1 KiB: its first 1 KiB as text with its
length and SHA-256), status, duration, and what the handler added with ``audit_note(request,
...)``: ``bytes_sent`` (the wire frames), ``result``, ``position_before``,
``position_after``, ``operation``.

The services' ``AuditRecord`` (``gateway.service.audit``) keeps the entries:
numbered and chained in a file that cannot tear, the newest in memory. An answer given before
any route authenticated the request names the principal of its ``Authorization`` header;
tokens in the query are masked (``gateway.api.redaction``).
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
from collections.abc import Mapping
from datetime import UTC, datetime
from typing import Annotated, Any

from fastapi import APIRouter, Depends, FastAPI, Query, Request
from pydantic import BaseModel, ConfigDict, Field
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from gateway.api.audit_log import PAGE_LIMIT
from gateway.api.middleware import audit_ahead
from gateway.api.middleware.asgi_status import call_noting_status
from gateway.api.problems import PROBLEM_RESPONSES
from gateway.api.redaction import redact
from gateway.api.security import Principal, principal_of, require
from gateway.errors import InvalidInputError
from gateway.service.audit import AuditRecord, AuditUnavailable, utc_now
from gateway.service.audit.bounds import VALUE_LIMIT
from gateway.service.control import ControlChange
from gateway.service.events import EventKind, ServiceEvent
from gateway.service.operations.types import Operation
from gateway.service.roles import Role

__all__ = [
    "MUTATING_METHODS",
    "AuditEntry",
    "AuditMiddleware",
    "AuditPage",
    "audit_note",
    "audit_router",
    "control_entry",
    "install_audit",
    "origin_entry",
    "resolution_entry",
]

log = logging.getLogger("gateway.audit")

MUTATING_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})
#: request bodies longer than this are recorded as their first bytes, as text
BODY_LIMIT = VALUE_LIMIT
#: keys the middleware writes; a handler's note never overwrites them
_CORE = frozenset(
    {
        "seq",
        "prev",
        "intent",
        "event",
        "time",
        "token",
        "role",
        "client",
        "method",
        "path",
        "query",
        "body",
        "status",
    }
)


def resolution_entry(op: Operation, prefix: str) -> dict[str, Any]:
    """The entry of an ``unknown`` operation resolved by reading the axis back (no request
    made it: the gateway did, when the controller answered again)."""
    return {
        "time": utc_now(),
        "token": op.holder,
        "method": "RESOLVE",
        "path": f"{prefix}/operations/{op.id}",
        "event": "operation_resolved",
        "position_before": op.position_before,
        "position_after": op.position,
        "operation": op.view().model_dump(mode="json"),
    }


def control_entry(change: ControlChange, prefix: str) -> dict[str, Any]:
    """The entry of a control change no request made (a key switch read by the gateway)."""
    ref = change.controller
    return {
        "time": utc_now(),
        "token": None,
        "method": "INPUT",
        "path": f"{prefix}/controllers/{ref.id}/control",
        "event": "control_changed",
        "result": change.view.state.value,
        "previous": change.previous.value,
        "cause": change.cause,
        "control": change.view.model_dump(mode="json"),
    }


def origin_entry(event: ServiceEvent, prefix: str) -> dict[str, Any] | None:
    """The entry of an origin lost by a controller reset (no request made it: the gateway
    saw it); None for other events."""
    if event.kind is not EventKind.ORIGIN or event.data.get("origin") != "lost":
        return None
    return {
        "time": utc_now(),
        "token": None,
        "method": "DEVICE",
        "path": f"{prefix}/axes/{event.data.get('axis')}",
        "event": "origin_lost",
        "result": "lost",
        "controller": event.data.get("controller"),
        "cause": event.data.get("cause"),
    }


def audit_note(request: Request, **fields: Any) -> None:
    """Add ``fields`` to the audit entry of ``request`` (``bytes_sent=[b"$1M1..."]``,
    ``result=...``, ``position_before=...``, ``position_after=...``, ``operation=...``)."""
    note = getattr(request.state, "audit", None)
    if not isinstance(note, dict):
        note = {}
        request.state.audit = note
    note.update(fields)


def _client(scope: Scope) -> str | None:
    client = scope.get("client")
    return f"{client[0]}:{client[1]}" if client else None


def _body(raw: bytes, total: int, sha256: str) -> dict[str, Any]:
    """The body's members of an entry: the JSON, or (longer than ``BODY_LIMIT``) its first
    bytes as text with its length and the SHA-256 of the whole."""
    if total == 0:
        return {"body": None}
    if total > BODY_LIMIT:
        return {
            "body": raw[:BODY_LIMIT].decode("utf-8", errors="ignore"),
            "body_truncated": True,
            "body_bytes": total,
            "body_sha256": sha256,
        }
    try:
        return {"body": json.loads(raw)}
    except ValueError:
        return {"body": raw.decode("utf-8", errors="replace")}


class AuditMiddleware:
    """Record every mutating HTTP request in ``audit`` once its response has started."""

    def __init__(self, app: ASGIApp, audit: AuditRecord) -> None:
        self.app = app
        self.audit = audit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """The ASGI entry point."""
        if scope["type"] != "http" or scope["method"] not in MUTATING_METHODS:
            await self.app(scope, receive, send)
            return
        state: dict[str, Any] = scope.setdefault("state", {})
        when, began = utc_now(), time.perf_counter()
        kept = bytearray()
        whole = hashlib.sha256()
        total = 0
        principal = principal_of(scope)
        if audit_ahead.acts(principal):
            assert principal is not None
            messages, raw, complete = await audit_ahead.pre_read(scope, receive)
            receive = audit_ahead.replay(messages, receive)
            if complete:
                body = _body(raw, len(raw), hashlib.sha256(raw).hexdigest())
                try:
                    state["audit_intent"] = await audit_ahead.write_ahead(
                        self.audit, scope, principal, _client(scope), body
                    )
                except AuditUnavailable as exc:
                    self._record(scope, state, when, began, raw, len(raw), hashlib.sha256(raw), 503)
                    await audit_ahead.refuse(scope, receive, send, exc)
                    return

        async def reading() -> Message:
            nonlocal total
            message = await receive()
            if message["type"] == "http.request":
                chunk: bytes = message.get("body", b"")
                total += len(chunk)
                whole.update(chunk)
                if len(kept) <= BODY_LIMIT:
                    kept.extend(chunk[: BODY_LIMIT + 1 - len(kept)])
            return message

        def record(status: int | None) -> None:
            self._record(scope, state, when, began, bytes(kept), total, whole, status)

        await call_noting_status(self.app, scope, reading, send, record)

    def _record(
        self,
        scope: Scope,
        state: Mapping[str, Any],
        when: str,
        began: float,
        raw: bytes,
        total: int,
        whole: Any,
        status: int | None,
    ) -> None:
        if state.get("auth_failed"):
            return  # one record per address a while (gateway.api.auth_failures)
        principal = state.get("principal")
        if not isinstance(principal, Principal):
            # Answered before any route authenticated it (404, 405, a refused body): the
            # entry still names who was refused.
            principal = principal_of(scope)
        entry: dict[str, Any] = {
            "time": when,
            "token": principal.name if isinstance(principal, Principal) else None,
            "role": str(principal.role) if isinstance(principal, Principal) else None,
            "client": _client(scope),
            "method": scope["method"],
            "path": scope["path"],
            "query": redact(scope.get("query_string", b"").decode("latin-1")),
            **_body(raw, total, whole.hexdigest()),
            "status": status,  # None: the client went away before any response
            "duration_ms": round((time.perf_counter() - began) * 1000, 3),
        }
        intent = state.get("audit_intent")
        if isinstance(intent, int):
            entry["intent"] = intent  # the entry written ahead, before anything was sent
        note = state.get("audit")
        if isinstance(note, Mapping):
            entry.update({k: v for k, v in note.items() if k not in _CORE})
        try:
            self.audit.record(entry)
        except Exception:  # the audit must never turn a response into an error
            log.exception("audit entry not recorded: %r", entry)


class AuditEntry(BaseModel):
    """One audited request (the handler's additions appear as extra members)."""

    model_config = ConfigDict(extra="allow")

    seq: int
    prev: str | None = Field(
        None, description="SHA-256 of the line before this one in the file (the chain)"
    )
    event: str | None = Field(
        None, description="``intent``: written ahead, before anything was sent"
    )
    intent: int | None = Field(
        None, description="the seq of the entry written ahead of this request"
    )
    time: str
    token: str | None = None
    role: str | None = None
    client: str | None = None
    method: str
    path: str
    query: str | None = Field(
        "", description="the query string; null in the entry of a DCMD or an OPC UA call"
    )
    body: Any = None
    status: int | str | None = Field(
        None, description="the HTTP status (a DCMD's too), or an OPC UA call's status code name"
    )
    duration_ms: float | None = None
    bytes_sent: list[str] | str | None = Field(
        None, description="the frames sent (longer than 1 KiB: cut, with bytes_sha256)"
    )
    result: Any = None
    position_before: Any = Field(None, description="pulses, before a motion request")
    position_after: Any = Field(None, description="pulses, when the motion ended")
    operation: Any = None


class AuditPage(BaseModel):
    """Entries of the audit log, oldest first, and the newest entry's number."""

    entries: list[AuditEntry]
    last_seq: int


def _since(text: str | None) -> tuple[int | None, datetime | None]:
    if text is None or text == "":
        return None, None
    if text.isdigit():
        if len(text) > 18:
            raise InvalidInputError(
                f"since {text[:24]}...: a sequence number has at most 18 digits",
                field="query.since",
                rule="a sequence number (at most 18 digits) or an ISO 8601 time",
            )
        return int(text), None
    try:
        moment = datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        raise InvalidInputError(
            f"since {text!r} is neither a sequence number nor an ISO 8601 time",
            field="query.since",
            rule="a sequence number (entries after it) or an ISO 8601 time",
        ) from None
    return None, moment if moment.tzinfo else moment.replace(tzinfo=UTC)


def audit_router(audit: AuditRecord) -> APIRouter:
    """``GET /api/v1/audit`` (admin) over ``audit``."""
    router = APIRouter(tags=["audit"])

    @router.get("/api/v1/audit", response_model=AuditPage, responses=PROBLEM_RESPONSES)
    async def read_audit(
        _: Annotated[Principal, Depends(require(Role.ADMIN))],
        limit: Annotated[int, Query(ge=1, le=PAGE_LIMIT)] = 100,
        since: Annotated[
            str | None,
            Query(max_length=64, description="a seq (entries after it) or an ISO 8601 time"),
        ] = None,
    ) -> AuditPage:
        """The audit log (admin): the newest ``limit`` entries, or the first after ``since``."""
        seq, after = _since(since)
        await audit.flush()  # outcomes still queued are written first: the page shows them
        page = await audit.page(limit=limit, since=seq, after=after)
        return AuditPage(entries=[AuditEntry(**e) for e in page], last_seq=audit.last_seq)

    return router


def install_audit(app: FastAPI, audit: AuditRecord) -> None:
    """Audit every mutating request of ``app`` into ``audit`` and serve ``GET /api/v1/audit``.

    Call after ``install_problem_handlers`` (so refused and failed requests are recorded with
    their status); ``await audit.close()`` at shutdown.
    """
    app.add_middleware(AuditMiddleware, audit=audit)
    app.include_router(audit_router(audit))
