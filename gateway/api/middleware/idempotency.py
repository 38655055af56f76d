"""``Idempotency-Key``: a retried POST or PUT returns the first result instead of acting again.

An ASGI middleware, so it covers every POST and PUT route of the app. The first response to a key is
stored per client (the ``Authorization`` header, hashed: one token, one client), key, method
and path, with a hash of the query and body; a retry with the same key:

* gets the stored status, headers and body again, with ``Idempotent-Replayed: true``;
* waits for the first request when that is still running (a motion waiting for its end);
* with another body or query is refused with 422 naming the header (the key was reused for a
  different request), and nothing is done.

Only responses after which the request may have acted are stored: 2xx, 5xx except 503
(``504``: the device did not answer, the move may have happened), and any answer that names
an operation in ``Location`` (a motion that ended ``failed`` is a 409 and may have moved the
axis). Other 4xx and 503 mean nothing was done (refused, leased, loop down: the outcome is
``not_done``), so a retry may act then. The
store in memory is bounded: ``capacity`` keys (``MEMORY_KEYS``, oldest dropped first; each holds
its response) for ``ttl`` seconds; the state store below it answers every key for ``ttl``
seconds (``clock``: seconds since the epoch), so memory holds the recent retries only.

Keys outlive the process: they are kept in the state store (``gateway.service.store``). The key of
a request that starts an operation is written with the operation before its first frame goes
out (``service.store.request_key`` tells the operation which key it serves), and the response
is written before it is sent. A retry that finds no key in memory looks there: a stored
response is replayed; a key whose request was cut short by a crash answers its operation as
it stands now (200 ``done``, 202 still running, the motion problem when it ``failed`` or is
``unknown``), replayed, and nothing acts again.

Every keyed request is written ``in progress`` to the state store before it is handed to its
route (``begin_key``), so the record is on disk before anything can act; when that write
fails the request is refused ``503`` with ``Retry-After`` and nothing acts (a stop passes all
the same: stopping twice is harmless, not stopping is not). A response after which nothing
was done takes the record away again. A retry after a restart that finds the record still
``in progress`` (the process died between acting and answering) is answered ``409``
``idempotency-outcome-unknown``, replayed, and nothing acts again
(``gateway.api.middleware.idempotency_answers``).
"""

from __future__ import annotations

import asyncio
import hashlib
import logging
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field

from fastapi import FastAPI
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from gateway.api.middleware.audit_ahead import STOP_ACTIONS, acts
from gateway.api.middleware.idempotency_answers import (
    HEADER,
    REPLAYED_HEADER,
    answer_operation,
    answer_outcome_unknown,
    refuse_unrecorded,
)
from gateway.api.problems import Problem, problem_response, problem_type
from gateway.api.security import principal_of
from gateway.service.store.database import StateStore
from gateway.service.store.records import (
    RequestKey,
    StoredKey,
    begin_key,
    drop_pending_key,
    load_key,
    request_key,
    save_response,
)

__all__ = [
    "HEADER",
    "MEMORY_KEYS",
    "REPLAYED_HEADER",
    "IdempotencyMiddleware",
    "IdempotencyStore",
    "install_idempotency",
]

log = logging.getLogger("gateway.api")

#: The methods whose keyed requests are kept: the ones that act.
KEYED_METHODS = frozenset({"POST", "PUT"})
#: keys (with their responses) kept in memory; older ones are answered from the state store
MEMORY_KEYS = 1_000
#: Keys are opaque to the gateway: printable ASCII, at most this long (a UUID is 36).
MAX_KEY_LENGTH = 255


@dataclass
class Entry:
    """One key: the request's fingerprint and, once answered, the stored response."""

    fingerprint: str
    created: float
    done: asyncio.Event = field(default_factory=asyncio.Event)
    status: int | None = None  # None: not stored (the first request left nothing to replay)
    headers: list[tuple[bytes, bytes]] = field(default_factory=list)
    body: bytes = b""


def _stored(status: int, headers: list[tuple[bytes, bytes]]) -> bool:
    """Whether a response may have acted, so a retry must get it rather than act again."""
    if status < 400 or (status >= 500 and status != 503):
        return True
    # A problem that names an operation: the motion was sent (motion_problems).
    return any(name.lower() == b"location" for name, _ in headers)


def _reused(key: str) -> Problem:
    """A key sent again with another query or body: it names one request only."""
    return _invalid(
        f"{HEADER} {key!r} was used for a different request to this path",
        f"one {HEADER} per request: a retry repeats the query and body exactly",
    )


class IdempotencyStore:
    """Bounded, expiring store of the first responses (``clock``: seconds, injectable)."""

    def __init__(
        self,
        capacity: int = MEMORY_KEYS,
        ttl: float = 86_400.0,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.capacity = capacity
        self.ttl = ttl
        self._clock = clock
        self._entries: OrderedDict[tuple[str, ...], Entry] = OrderedDict()

    def __len__(self) -> int:
        return len(self._entries)

    def now(self) -> float:
        """The store's clock (seconds since the epoch: keys are compared across restarts)."""
        return self._clock()

    def get(self, key: tuple[str, ...]) -> Entry | None:
        """The live entry of ``key``."""
        self._expire()
        return self._entries.get(key)

    def begin(self, key: tuple[str, ...], fingerprint: str) -> Entry:
        """A new entry for a first request."""
        entry = Entry(fingerprint, self._clock())
        self._entries[key] = entry
        while len(self._entries) > self.capacity:
            self._entries.popitem(last=False)
        return entry

    def forget(self, key: tuple[str, ...], entry: Entry) -> None:
        """Drop ``entry`` (its response is not stored: a retry acts again)."""
        if self._entries.get(key) is entry:
            del self._entries[key]

    def _expire(self) -> None:
        limit = self._clock() - self.ttl
        while self._entries:
            oldest = next(iter(self._entries.values()))
            if oldest.created > limit:
                break
            self._entries.popitem(last=False)


def _header(scope: Scope, name: bytes) -> str | None:
    for key, value in scope.get("headers", []):
        if key.lower() == name:
            return str(value.decode("latin-1"))
    return None


def _invalid(detail: str, rule: str) -> Problem:
    return Problem(
        type=problem_type("invalid-input"),
        title="Invalid input",
        status=422,
        detail=detail,
        field=f"header.{HEADER}",
        rule=rule,
    )


class IdempotencyMiddleware:
    """Replays the stored response of a POST or PUT retried with the same ``Idempotency-Key``."""

    def __init__(self, app: ASGIApp, store: IdempotencyStore, durable: StateStore) -> None:
        self.app = app
        self.store = store
        self.durable = durable

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Serve one ASGI connection: POSTs and PUTs with a key are stored or replayed."""
        if scope["type"] != "http" or scope.get("method") not in KEYED_METHODS:
            await self.app(scope, receive, send)
            return
        key = _header(scope, b"idempotency-key")
        if key is None:
            await self.app(scope, receive, send)
            return
        if not 1 <= len(key) <= MAX_KEY_LENGTH or not key.isascii() or not key.isprintable():
            problem = _invalid(
                f"{HEADER} {key[:40]!r} is not a valid key",
                f"{HEADER}: 1-{MAX_KEY_LENGTH} printable ASCII characters",
            )
            await problem_response(problem)(scope, receive, send)
            return
        if not acts(principal_of(scope)):
            # Nobody who may act (no token, a wrong one, a viewer's): the route refuses it.
            # Nothing is kept for it, on disk or in memory, so keys sent without a token cost
            # the gateway no write and push no real client's key out of the bounded store.
            await self.app(scope, receive, send)
            return
        body, more = await _read_body(receive)
        client = hashlib.sha256((_header(scope, b"authorization") or "").encode()).hexdigest()
        ident = (client, key, str(scope["method"]), str(scope.get("path", "")))
        digest = hashlib.sha256(scope.get("query_string", b"") + b"\x00" + body).hexdigest()
        durable_key = RequestKey.of(ident, digest, self.store.now())
        entry = self.store.get(ident)
        if entry is None:
            stored = await self._stored(durable_key)
            entry = self.store.get(ident)  # a request with the key may have begun meanwhile
            if entry is None and stored is not None:
                if stored.fingerprint != digest:
                    await problem_response(_reused(key))(scope, receive, send)
                    return
                if stored.status is not None:
                    await _send(send, stored.status, stored.headers, stored.body)
                    return
                if stored.operation is not None:
                    await answer_operation(scope, receive, send, stored.operation)
                    return
                await answer_outcome_unknown(scope, receive, send, key, stored.created)
                return
        while entry is not None:
            if entry.fingerprint != digest:
                await problem_response(_reused(key))(scope, receive, send)
                return
            await entry.done.wait()
            if entry.status is not None:
                await _replay(entry, send)
                return
            entry = self.store.get(ident)  # the first was not stored: this one acts
        entry = self.store.begin(ident, digest)  # a retry from now on waits for this one
        answered = False
        try:
            refused = await self._begin(durable_key, scope)
            if refused is not None:
                await refuse_unrecorded(scope, receive, send, key, refused)
                return
            token = request_key.set(durable_key)
            try:
                answered = await self._first(
                    scope, _replaying(more, receive), send, entry, durable_key
                )
            finally:
                request_key.reset(token)
        finally:
            if entry.status is None:
                if answered:  # answered without acting: a retry may act
                    self.durable.post(lambda c: drop_pending_key(c, durable_key))
                # (queued before any retry's read of the key: the store's one thread)
                self.store.forget(ident, entry)
            entry.done.set()

    async def _begin(self, key: RequestKey, scope: Scope) -> str | None:
        """Write ``key`` ``in progress`` before its request may act; why it could not be
        written, when it must be refused (a stop is never refused for it)."""
        try:
            await self.durable.run(lambda c: begin_key(c, key))
        except Exception as exc:
            log.error("idempotency: a key cannot be recorded before its request: %s", exc)
            path = str(scope.get("path", "")).rstrip("/")
            if path.rsplit("/", 1)[-1] in STOP_ACTIONS:
                return None
            return str(exc) or type(exc).__name__
        return None

    async def _stored(self, key: RequestKey) -> StoredKey | None:
        try:
            ttl = self.store.ttl
            return await self.durable.run(lambda c: load_key(c, key.ident, key.created, ttl))
        except Exception as exc:  # unreadable: the key is as unknown as before the store
            log.error("idempotency: the state store cannot be read: %s", exc)
            return None

    async def _first(
        self, scope: Scope, receive: Receive, send: Send, entry: Entry, key: RequestKey
    ) -> bool:
        """Serve the first request of a key; whether its response was given whole."""
        answered = False
        status = 0
        headers: list[tuple[bytes, bytes]] = []
        chunks: list[bytes] = []

        async def capture(message: Message) -> None:
            nonlocal status, headers, answered
            if message["type"] == "http.response.start":
                status = int(message["status"])
                headers = list(message.get("headers", []))
            elif message["type"] == "http.response.body":
                chunks.append(bytes(message.get("body", b"")))
                if not message.get("more_body", False):
                    answered = True
                    if _stored(status, headers):
                        entry.headers, entry.body = headers, b"".join(chunks)
                        entry.status = status
                        await self._keep(key, entry)
            await send(message)

        await self.app(scope, receive, capture)
        return answered

    async def _keep(self, key: RequestKey, entry: Entry) -> None:
        """The response on disk before the client has it: a retry after a restart gets it."""
        status, headers, body = entry.status, entry.headers, entry.body
        assert status is not None
        try:
            await self.durable.run(lambda c: save_response(c, key, status, headers, body))
        except Exception as exc:  # it has acted already: answer all the same, and say so
            log.error("idempotency: the response to a key was not stored: %s", exc)


async def _read_body(receive: Receive) -> tuple[bytes, list[Message]]:
    """The whole request body, and the messages read (to hand on unchanged)."""
    messages: list[Message] = []
    parts: list[bytes] = []
    while True:
        message = await receive()
        messages.append(message)
        if message["type"] != "http.request":
            break
        parts.append(bytes(message.get("body", b"")))
        if not message.get("more_body", False):
            break
    return b"".join(parts), messages


def _replaying(read: list[Message], receive: Receive) -> Receive:
    """A ``receive`` that gives the app the messages already read, then the real ones."""
    pending = list(read)

    async def again() -> Message:
        if pending:
            return pending.pop(0)
        return await receive()

    return again


async def _replay(entry: Entry, send: Send) -> None:
    assert entry.status is not None
    await _send(send, entry.status, entry.headers, entry.body)


async def _send(send: Send, status: int, stored: list[tuple[bytes, bytes]], body: bytes) -> None:
    headers = [(k, v) for k, v in stored if k.lower() != REPLAYED_HEADER.lower().encode()]
    headers.append((REPLAYED_HEADER.lower().encode(), b"true"))
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body, "more_body": False})


def install_idempotency(
    app: FastAPI,
    durable: StateStore,
    *,
    capacity: int = MEMORY_KEYS,
    ttl: float = 86_400.0,
    clock: Callable[[], float] = time.time,
) -> IdempotencyStore:
    """Make every POST and PUT of ``app`` honour ``Idempotency-Key``; the store
    (``app.state.idempotency``), backed by ``durable`` (the state store) across restarts.

    Install it after ``install_problem_handlers`` and before the audit middleware, so that a
    replay is audited too and the replayed response is the first one as the client saw it.
    """
    store = IdempotencyStore(capacity, ttl, clock)
    app.add_middleware(IdempotencyMiddleware, store=store, durable=durable)
    app.state.idempotency = store
    return store
