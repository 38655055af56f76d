"""The entry written ahead of an HTTP request that may act, before the route sees it.

Every request that can reach the wire (a mutating method from a principal who may act: an
operator or an admin, anyone in no-auth mode) crosses ``AuditMiddleware`` before its route
runs; there its entry goes to the file first (``AuditRecord.write_ahead``: written, and
``fsync``-ed for motion by default), and only then is the request handed on. So whatever the
route sends, its record is on disk before the first frame, also when the gateway is killed
a moment later. When the entry cannot be written, the request is answered ``503`` with
``Retry-After`` and never reaches a route: nothing is sent. A stop passes whatever happens
to its entry (``gateway.service.audit.record``).

The entry written when the response has started (its outcome) names this one: ``intent``.
"""

from __future__ import annotations

from typing import Any

from starlette.requests import Request
from starlette.types import Message, Receive, Scope, Send

from gateway.api.middleware.body_gate import BODY_LIMIT
from gateway.api.problems import Problem, problem_response, problem_type
from gateway.api.redaction import redact
from gateway.api.security import Principal
from gateway.service.audit import AuditRecord, AuditUnavailable, utc_now
from gateway.service.roles import Role

__all__ = ["MOTION_ACTIONS", "STOP_ACTIONS", "acts", "pre_read", "refuse", "replay", "write_ahead"]

#: the last path segment of a request that moves an axis (its entry is fsync-ed by default)
MOTION_ACTIONS = frozenset({"move", "home", "jog", "step"})
#: the last path segment of a stop: never refused for its entry
STOP_ACTIONS = frozenset({"stop"})


def acts(principal: Principal | None) -> bool:
    """Whether a request from ``principal`` may act: the operator role or more.
    (Refused ones, 401 and 403, are recorded once, after their answer.)"""
    return principal is not None and principal.role.allows(Role.OPERATOR)


def _declared_length(scope: Scope) -> int | None:
    for name, value in scope.get("headers", ()):
        if name == b"content-length":
            try:
                return int(value)
            except ValueError:
                return None
    return None


async def pre_read(scope: Scope, receive: Receive) -> tuple[list[Message], bytes, bool]:
    """The request's body messages read before the route, their bytes, and whether that is
    the whole body within what the body gate takes (False: the gate refuses it, so there is
    nothing to write ahead of; what was read is handed on all the same)."""
    declared = _declared_length(scope)
    if declared is not None and declared > BODY_LIMIT:
        return [], b"", False  # refused by the gate from the header, unread
    messages: list[Message] = []
    body = bytearray()
    while True:
        message = await receive()
        messages.append(message)
        if message["type"] != "http.request":
            return messages, bytes(body), False  # the client went away
        body.extend(message.get("body", b""))
        if len(body) > BODY_LIMIT:
            return messages, bytes(body), False
        if not message.get("more_body", False):
            return messages, bytes(body), True


def replay(messages: list[Message], receive: Receive) -> Receive:
    """A ``receive`` that gives ``messages`` first, then what ``receive`` gives."""
    kept = list(messages)

    async def receiving() -> Message:
        if kept:
            return kept.pop(0)
        return await receive()

    return receiving


def _action(scope: Scope) -> str:
    path: str = scope["path"]
    return path.rstrip("/").rsplit("/", 1)[-1]


async def write_ahead(
    audit: AuditRecord,
    scope: Scope,
    principal: Principal,
    client: str | None,
    body: dict[str, Any],
) -> int | None:
    """Write the entry of the request of ``scope`` now; its seq (None: a stop whose entry is
    queued). ``AuditUnavailable`` when it cannot be written."""
    action = _action(scope)
    entry = {
        "time": utc_now(),
        "event": "intent",
        "token": principal.name,
        "role": str(principal.role),
        "client": client,
        "method": scope["method"],
        "path": scope["path"],
        "query": redact(scope.get("query_string", b"").decode("latin-1")),
        **body,  # body (and, cut: body_truncated, body_bytes, body_sha256)
    }
    return await audit.write_ahead(
        entry, motion=action in MOTION_ACTIONS, stop=action in STOP_ACTIONS
    )


async def refuse(scope: Scope, receive: Receive, send: Send, exc: AuditUnavailable) -> None:
    """Answer ``503`` with ``Retry-After``: the request's entry could not be written."""
    problem = Problem(
        type=problem_type("audit-unavailable"),
        title="Audit log unavailable",
        status=503,
        detail=str(exc),
        field="audit",
        rule="nothing acts before its audit entry is on disk",
        outcome="not_done",
    )
    response = problem_response(
        problem, Request(scope), {"Retry-After": str(max(1, exc.retry_after))}
    )
    await response(scope, receive, send)
