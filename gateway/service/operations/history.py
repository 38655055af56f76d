"""Operations older than what memory keeps, read back from the state store.

``Operations`` keeps the newest ``MEMORY`` operations in memory (each a few kilobytes with its
frames and request): what ``GET /operations`` serves fast and what the motion watch follows.
Every operation is also in the state store from before its first frame until its retention
ends (``OPERATION_RETENTION``, a week). ``find`` and ``newest`` answer from memory when it
holds the answer and from the store otherwise, so that ``GET /operations/{id}``, an
``Idempotency-Key`` retried within its day and a list that pages back see every operation the
store keeps, as they did when memory held 10,000.
"""

from __future__ import annotations

import json
import sqlite3
from typing import Any

from gateway.errors import NotFoundError
from gateway.service.operations.book import Operations
from gateway.service.operations.durable import from_record
from gateway.service.operations.types import Operation, OperationState

__all__ = ["find", "newest"]


def _number(ident: str) -> int | None:
    """The number in an operation id (``op-<number>-<time>``)."""
    parts = ident.split("-")
    if len(parts) != 3 or parts[0] != "op" or not parts[1].isdigit():
        return None
    return int(parts[1])


def _load_one(connection: sqlite3.Connection, ident: str) -> dict[str, Any] | None:
    row = connection.execute("SELECT record FROM operations WHERE id = ?", (ident,)).fetchone()
    return None if row is None else dict(json.loads(row[0]))


def _load_before(
    connection: sqlite3.Connection, number: int, axis: str | None, state: str | None, limit: int
) -> list[dict[str, Any]]:
    rows = connection.execute(
        "SELECT record FROM operations WHERE number < ? AND (? IS NULL OR state = ?) "
        "AND (? IS NULL OR json_extract(record, '$.axis') = ?) ORDER BY number DESC LIMIT ?",
        (number, state, state, axis, axis, limit),
    ).fetchall()
    return [json.loads(row[0]) for row in rows]


async def find(operations: Operations, ident: str) -> Operation:
    """Operation ``ident`` from memory or the store; ``NotFoundError`` when neither has it."""
    try:
        return operations.get(ident)
    except NotFoundError:
        if _number(ident) is None:
            raise
    record = await operations.runtime.store.run(lambda c: _load_one(c, ident))
    op = None if record is None else from_record(record, operations.runtime.topology)
    if op is None:
        raise NotFoundError("operation", ident)
    return op


async def newest(
    operations: Operations,
    *,
    axis: str | None = None,
    state: OperationState | None = None,
    limit: int = 100,
) -> list[Operation]:
    """The newest ``limit`` operations first (of ``axis``, in ``state``): those in memory,
    then, when memory has forgotten some, older ones from the store."""
    found = operations.list(axis=axis, state=state, limit=limit)
    if len(found) >= limit or not operations.forgotten:
        return found
    kept = operations.list(limit=operations.retention)
    oldest = min((n for n in (_number(op.id) for op in kept) if n is not None), default=None)
    if oldest is None:
        return found
    wanted = None if state is None else state.value
    records = await operations.runtime.store.run(
        lambda c: _load_before(c, oldest, axis, wanted, limit - len(found))
    )
    topology = operations.runtime.topology
    return found + [op for op in (from_record(r, topology) for r in records) if op is not None]
