"""The audit log (issue 5, "Security and audit"): every mutating request, one JSON line each.

``AuditMiddleware`` appends an entry for every POST, PUT, PATCH and DELETE, refused ones too
(401, 403, 422): time (ISO 8601 UTC), token name and role, client address, method, path,
query, request body (JSON, its first 4 KiB as text when longer), status, duration, and what
the handler added with ``audit_note(request, ...)``: ``bytes_sent`` (the wire frames),
``result``, ``position_before``, ``position_after``, ``operation``.

``AuditLog`` keeps the newest entries in memory (a bounded ring, for ``GET /api/v1/audit``) and
appends them to its file from a writer task, a batch at a time in a worker thread, so a slow
disk never blocks the event loop; ``await close()`` writes everything still queued.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import time
from collections import deque
from collections.abc import Iterable, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated, Any

from fastapi import APIRouter, Depends, FastAPI, Query, Request
from pydantic import BaseModel, ConfigDict
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from gateway.api.problems import PROBLEM_RESPONSES
from gateway.api.security import Principal, require
from gateway.errors import InvalidInputError
from gateway.service.operation_types import Operation
from gateway.service.roles import Role

__all__ = [
    "MUTATING_METHODS",
    "AuditEntry",
    "AuditLog",
    "AuditMiddleware",
    "AuditPage",
    "audit_note",
    "install_audit",
    "resolution_entry",
    "router",
]

log = logging.getLogger("gateway.audit")

MUTATING_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})
#: request bodies longer than this are recorded as their first bytes, as text
BODY_LIMIT = 4096
#: entries kept in memory for ``GET /api/v1/audit``
MEMORY = 10_000
#: keys the middleware writes; a handler's note never overwrites them
_CORE = frozenset(
    {"seq", "time", "token", "role", "client", "method", "path", "query", "body", "status"}
)


def utc_now() -> str:
    """Now as ISO 8601 UTC with milliseconds (``2025-01-31T12:00:00.000Z``)."""
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


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


def _plain(value: Any) -> Any:
    """``value`` made JSON-safe: bytes (wire frames) as Latin-1 text, tuples as lists."""
    if isinstance(value, bytes | bytearray):
        return bytes(value).decode("latin-1")
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple | set | frozenset):
        return [_plain(v) for v in value]
    if isinstance(value, BaseModel):
        return value.model_dump(mode="json")
    if value is None or isinstance(value, str | int | float | bool):
        return value
    return str(value)


def audit_note(request: Request, **fields: Any) -> None:
    """Add ``fields`` to the audit entry of ``request`` (``bytes_sent=[b"$1M1..."]``,
    ``result=...``, ``position_before=...``, ``position_after=...``, ``operation=...``)."""
    note = getattr(request.state, "audit", None)
    if not isinstance(note, dict):
        note = {}
        request.state.audit = note
    note.update(fields)


class AuditLog:
    """The newest entries in memory, every entry appended to ``path`` (None: memory only)."""

    def __init__(self, path: Path | None = None, *, memory: int = MEMORY) -> None:
        self.path = path
        self._ring: deque[dict[str, Any]] = deque(maxlen=memory)
        self._seq = 0
        self._pending: asyncio.Queue[str] | None = None
        self._writer: asyncio.Task[None] | None = None
        #: lines that could not be written (the disk failed); they stay in memory
        self.write_errors = 0

    @property
    def last_seq(self) -> int:
        """The number of the newest entry (0: none yet)."""
        return self._seq

    def record(self, entry: Mapping[str, Any]) -> dict[str, Any]:
        """Number ``entry``, keep it, queue it for the file; the stored entry."""
        self._seq += 1
        stored = {"seq": self._seq, **_plain(entry)}
        self._ring.append(stored)
        if self.path is not None:
            self._queue_line(json.dumps(stored, ensure_ascii=False, separators=(",", ":")))
        return stored

    def entries(
        self, *, limit: int = 100, since: int | None = None, after: datetime | None = None
    ) -> list[dict[str, Any]]:
        """Entries oldest first: the first ``limit`` after ``since`` (a seq) or ``after`` (a
        time) when given, else the newest ``limit``."""
        selected: Iterable[dict[str, Any]] = self._ring
        if since is not None:
            selected = (e for e in selected if e["seq"] > since)
        if after is not None:
            stamp = after.astimezone(UTC).isoformat(timespec="milliseconds")
            stamp = stamp.replace("+00:00", "Z")
            selected = (e for e in selected if e["time"] > stamp)
        found = list(selected)
        if since is None and after is None:
            return found[-limit:]
        return found[:limit]

    # ------------------------------------------------------------------ the file

    def _queue_line(self, line: str) -> None:
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # no event loop (a script): write now
            self._write([line])
            return
        if self._pending is None:
            self._pending = asyncio.Queue()
        self._pending.put_nowait(line)
        if self._writer is None or self._writer.done():
            self._writer = loop.create_task(self._write_forever(self._pending), name="audit")

    async def _write_forever(self, pending: asyncio.Queue[str]) -> None:
        while True:
            batch = [await pending.get()]
            while not pending.empty() and len(batch) < 1000:
                batch.append(pending.get_nowait())
            try:
                await asyncio.to_thread(self._write, batch)
            finally:
                for _ in batch:
                    pending.task_done()

    def _write(self, lines: list[str]) -> None:
        assert self.path is not None
        try:
            with self.path.open("a", encoding="utf-8") as file:
                file.write("".join(line + "\n" for line in lines))
        except OSError:
            self.write_errors += len(lines)
            log.exception("audit log %s: %d entries not written", self.path, len(lines))

    async def flush(self) -> None:
        """Wait until every entry recorded so far is in the file."""
        if self._pending is not None and self._writer is not None and not self._writer.done():
            await self._pending.join()

    async def close(self) -> None:
        """Write what is queued, then stop the writer (graceful shutdown)."""
        await self.flush()
        if self._writer is not None:
            self._writer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._writer
            self._writer = None
        self._pending = None


def _client(scope: Scope) -> str | None:
    client = scope.get("client")
    return f"{client[0]}:{client[1]}" if client else None


def _body(raw: bytes, total: int) -> tuple[Any, bool]:
    if total == 0:
        return None, False
    if total > BODY_LIMIT:
        return raw[:BODY_LIMIT].decode("utf-8", errors="replace"), True
    try:
        return json.loads(raw), False
    except ValueError:
        return raw.decode("utf-8", errors="replace"), False


class AuditMiddleware:
    """Record every mutating HTTP request in ``audit`` once its response has started."""

    def __init__(self, app: ASGIApp, audit: AuditLog) -> None:
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
        total = 0
        status: int | None = None

        async def tee(message: Message) -> None:
            nonlocal status
            if message["type"] == "http.response.start":
                status = int(message["status"])
            await send(message)

        async def reading() -> Message:
            nonlocal total
            message = await receive()
            if message["type"] == "http.request":
                chunk: bytes = message.get("body", b"")
                total += len(chunk)
                if len(kept) <= BODY_LIMIT:
                    kept.extend(chunk[: BODY_LIMIT + 1 - len(kept)])
            return message

        try:
            await self.app(scope, reading, tee)
        except Exception:
            status = status or 500
            raise
        finally:
            self._record(scope, state, when, began, bytes(kept), total, status)

    def _record(
        self,
        scope: Scope,
        state: Mapping[str, Any],
        when: str,
        began: float,
        raw: bytes,
        total: int,
        status: int | None,
    ) -> None:
        principal = state.get("principal")
        body, truncated = _body(raw, total)
        entry: dict[str, Any] = {
            "time": when,
            "token": principal.name if isinstance(principal, Principal) else None,
            "role": str(principal.role) if isinstance(principal, Principal) else None,
            "client": _client(scope),
            "method": scope["method"],
            "path": scope["path"],
            "query": scope.get("query_string", b"").decode("latin-1"),
            "body": body,
            "status": status,  # None: the client went away before any response
            "duration_ms": round((time.perf_counter() - began) * 1000, 3),
        }
        if truncated:
            entry["body_truncated"] = True
            entry["body_bytes"] = total
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
    time: str
    token: str | None = None
    role: str | None = None
    client: str | None = None
    method: str
    path: str
    query: str = ""
    body: Any = None
    status: int | None = None
    duration_ms: float | None = None
    bytes_sent: list[str] | None = None
    result: Any = None
    position_before: Any = None
    position_after: Any = None
    operation: Any = None


class AuditPage(BaseModel):
    """Entries of the audit log, oldest first, and the newest entry's number."""

    entries: list[AuditEntry]
    last_seq: int


router = APIRouter(tags=["audit"])


def _since(text: str | None) -> tuple[int | None, datetime | None]:
    if text is None or text == "":
        return None, None
    if text.isdigit():
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


@router.get("/api/v1/audit", response_model=AuditPage, responses=PROBLEM_RESPONSES)
async def read_audit(
    request: Request,
    _: Annotated[Principal, Depends(require(Role.ADMIN))],
    limit: Annotated[int, Query(ge=1, le=MEMORY)] = 100,
    since: Annotated[
        str | None, Query(description="a seq (entries after it) or an ISO 8601 time")
    ] = None,
) -> AuditPage:
    """The audit log (admin): the newest ``limit`` entries, or the first after ``since``."""
    audit: AuditLog = request.app.state.audit
    seq, after = _since(since)
    return AuditPage(
        entries=[AuditEntry(**e) for e in audit.entries(limit=limit, since=seq, after=after)],
        last_seq=audit.last_seq,
    )


def install_audit(app: FastAPI, audit: AuditLog) -> None:
    """Audit every mutating request of ``app`` into ``audit`` and serve ``GET /api/v1/audit``.

    Call after ``install_problem_handlers`` (so refused and failed requests are recorded with
    their status); ``await audit.close()`` at shutdown.
    """
    app.state.audit = audit
    app.add_middleware(AuditMiddleware, audit=audit)
    app.include_router(router)
