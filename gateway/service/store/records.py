"""The rows of the state database: operations and idempotency keys, and how long they stay.

Each function here takes the connection and runs in the store's thread (``StateStore.run`` /
``post``). An operation and the key of the request that started it are written in one
transaction, before the operation's first frame goes out (``insert_operation``): after a
crash, a retry with that key finds the operation and never starts another.

Retention: an operation stays ``OPERATION_RETENTION`` seconds after it ended (one that never
ended stays until it is resolved); a key stays ``KEY_RETENTION`` seconds after its request.
``purge`` drops the rest (at each start).

Every other keyed request is written ``in progress`` (``begin_key``: its fingerprint, no
operation, no response) before its route acts, and its response replaces that once it is
ready (``save_response``). A row that is still ``in progress`` after a restart is a request
whose outcome was never recorded: it may have acted, so a retry must not act again
(``StoredKey.in_progress``). A response after which nothing was done takes the row away
(``drop_pending_key``), so a retry may act then.
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any

from gateway.service.store.database import transaction, write_counter

__all__ = [
    "KEY_RETENTION",
    "OPERATION_COUNTER",
    "OPERATION_RETENTION",
    "RequestKey",
    "StoredKey",
    "begin_key",
    "drop_pending_key",
    "insert_operation",
    "load_key",
    "load_operations",
    "purge",
    "request_key",
    "save_operation",
    "save_response",
]

#: Seconds an ended operation stays readable (``GET /operations/{id}``): 7 days.
OPERATION_RETENTION = 7 * 86_400.0
#: Seconds a key answers its first response: 24 hours.
KEY_RETENTION = 86_400.0
#: The counter of operation numbers (an id's number never comes back after a restart).
OPERATION_COUNTER = "operation"


@dataclass(frozen=True)
class RequestKey:
    """The ``Idempotency-Key`` of the request being served: who, which key, where, and the
    fingerprint of its query and body."""

    ident: str  # SHA-256 of client, key, method and path: the row's primary key
    fingerprint: str
    created: float  # seconds since the epoch

    @classmethod
    def of(cls, parts: tuple[str, ...], fingerprint: str, created: float) -> RequestKey:
        """The key of ``parts`` (client hash, key, method, path), asked at ``created``."""
        ident = hashlib.sha256("\x00".join(parts).encode()).hexdigest()
        return cls(ident, fingerprint, created)


#: The key of the request in progress, set by the API's idempotency layer around the request:
#: an operation started while serving it is written with it (``insert_operation``).
request_key: ContextVar[RequestKey | None] = ContextVar("request_key", default=None)


@dataclass(frozen=True)
class StoredKey:
    """A key as the database holds it: the operation it started and the response given."""

    fingerprint: str
    created: float
    operation: str | None
    status: int | None
    headers: list[tuple[bytes, bytes]]
    body: bytes

    @property
    def in_progress(self) -> bool:
        """Accepted, and then neither an operation nor a response was recorded: the request
        may or may not have acted (the process stopped before it answered)."""
        return self.operation is None and self.status is None


def begin_key(connection: sqlite3.Connection, key: RequestKey) -> None:
    """Key ``key`` is ``in progress``: on disk before its request acts. It replaces a row
    of the same ident left past its retention (the caller found no live one)."""
    connection.execute(
        "INSERT INTO idempotency_keys (ident, fingerprint, created) VALUES (?, ?, ?) "
        "ON CONFLICT (ident) DO UPDATE SET fingerprint = excluded.fingerprint, "
        "created = excluded.created, operation = NULL, status = NULL, headers = NULL, "
        "body = NULL",
        (key.ident, key.fingerprint, key.created),
    )


def drop_pending_key(connection: sqlite3.Connection, key: RequestKey) -> None:
    """Take away the ``in progress`` row of ``key``: its request was answered without acting
    (refused, 4xx or 503), so a retry may act. A row with an operation or a response stays."""
    connection.execute(
        "DELETE FROM idempotency_keys WHERE ident = ? AND created = ? "
        "AND operation IS NULL AND status IS NULL",
        (key.ident, key.created),
    )


def insert_operation(
    connection: sqlite3.Connection, number: int, record: dict[str, Any], key: RequestKey | None
) -> None:
    """Operation ``record`` (number ``number``) and the key that started it, in one
    transaction."""
    with transaction(connection):
        connection.execute(
            "INSERT INTO operations (id, number, state, created, ended, record) "
            "VALUES (?, ?, ?, ?, ?, ?)",
            (record["id"], number, record["state"], record["created"], record["ended"],
             json.dumps(record)),
        )  # fmt: skip
        write_counter(connection, OPERATION_COUNTER, number)
        if key is not None:
            connection.execute(
                "INSERT INTO idempotency_keys (ident, fingerprint, created, operation) "
                "VALUES (?, ?, ?, ?) ON CONFLICT (ident) DO UPDATE SET "
                "operation = coalesce(operation, excluded.operation)",
                (key.ident, key.fingerprint, key.created, record["id"]),
            )


def save_operation(connection: sqlite3.Connection, record: dict[str, Any]) -> None:
    """The operation's record as it is now."""
    connection.execute(
        "UPDATE operations SET state = ?, ended = ?, record = ? WHERE id = ?",
        (record["state"], record["ended"], json.dumps(record), record["id"]),
    )


def load_operations(connection: sqlite3.Connection, limit: int) -> list[dict[str, Any]]:
    """The newest ``limit`` operations and every one not ended, oldest first."""
    rows = connection.execute(
        "SELECT record FROM operations WHERE ended IS NULL OR id IN "
        "(SELECT id FROM operations ORDER BY number DESC LIMIT ?) ORDER BY number",
        (limit,),
    ).fetchall()
    return [json.loads(row[0]) for row in rows]


def load_key(
    connection: sqlite3.Connection, ident: str, now: float, ttl: float = KEY_RETENTION
) -> StoredKey | None:
    """Key ``ident`` unless it is ``ttl`` seconds old."""
    row = connection.execute(
        "SELECT fingerprint, created, operation, status, headers, body FROM idempotency_keys "
        "WHERE ident = ? AND created > ?",
        (ident, now - ttl),
    ).fetchone()
    if row is None:
        return None
    fingerprint, created, operation, status, headers, body = row
    pairs = [
        (name.encode("latin-1"), value.encode("latin-1"))
        for name, value in json.loads(headers or "[]")
    ]
    return StoredKey(fingerprint, created, operation, status, pairs, bytes(body or b""))


def save_response(
    connection: sqlite3.Connection,
    key: RequestKey,
    status: int,
    headers: list[tuple[bytes, bytes]],
    body: bytes,
) -> None:
    """The response given to the request of ``key`` (the operation it started stays)."""
    pairs = json.dumps([(n.decode("latin-1"), v.decode("latin-1")) for n, v in headers])
    connection.execute(
        "INSERT INTO idempotency_keys (ident, fingerprint, created, status, headers, body) "
        "VALUES (?, ?, ?, ?, ?, ?) ON CONFLICT (ident) DO UPDATE SET status = excluded.status, "
        "headers = excluded.headers, body = excluded.body",
        (key.ident, key.fingerprint, key.created, status, pairs, body),
    )


def purge(connection: sqlite3.Connection, now: float) -> tuple[int, int]:
    """Drop the operations and keys past their retention; how many of each."""
    with transaction(connection):
        ops = connection.execute(
            "DELETE FROM operations WHERE ended IS NOT NULL AND ended < ?",
            (now - OPERATION_RETENTION,),
        ).rowcount
        keys = connection.execute(
            "DELETE FROM idempotency_keys WHERE created < ?", (now - KEY_RETENTION,)
        ).rowcount
    return ops, keys
