"""The audit log's store: the newest entries in memory, every entry in a JSON-lines file.

``AuditLog`` keeps the newest entries in a bounded ring (for ``GET /api/v1/audit``) and
appends them to its file from a writer task, a batch at a time in a worker thread, so a slow
disk never blocks the event loop; ``await close()`` writes everything still queued.

The file holds every entry whatever a client sends: a line that UTF-8 cannot hold (a lone
surrogate) is written with JSON escapes instead. A write that fails keeps its lines for the
next write, is logged, turns ``healthy`` false (``/readyz`` answers 503) and is counted
(``rc233_audit_write_errors_total`` in ``/metrics``) until a write succeeds again.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
from collections import deque
from collections.abc import Iterable, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from gateway.api.exposition import Exposition

__all__ = ["MEMORY", "AuditLog"]

log = logging.getLogger("gateway.audit")

#: entries kept in memory for ``GET /api/v1/audit``
MEMORY = 10_000


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
        #: why the last write failed (None: it did not)
        self.last_error: str | None = None
        #: lines of failed writes, written first by the next write
        self._unwritten: deque[str] = deque(maxlen=memory)

    @property
    def healthy(self) -> bool:
        """False while the last write to the file failed (``/readyz`` says so)."""
        return self.last_error is None

    def exposition(self) -> str:
        """The audit log's metrics in the Prometheus text format."""
        out = Exposition()
        out.family("rc233_audit_entries_total", "counter", "Audit entries recorded.")
        out.sample("rc233_audit_entries_total", {}, self._seq)
        out.family(
            "rc233_audit_write_errors_total", "counter", "Audit lines a write to the file failed."
        )
        out.sample("rc233_audit_write_errors_total", {}, self.write_errors)
        out.family("rc233_audit_log_ok", "gauge", "0 while the last write to the file failed.")
        out.sample("rc233_audit_log_ok", {}, 1 if self.healthy else 0)
        return out.text()

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
            self._queue_line(_line(stored))
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
        waiting = [*self._unwritten, *lines]
        try:
            with self.path.open("a", encoding="utf-8") as file:
                file.write("".join(line + "\n" for line in waiting))
        except Exception as exc:  # whatever it is, the writer lives and the lines are kept
            self.write_errors += len(lines)
            self.last_error = f"{self.path}: {exc}"
            self._unwritten.extend(lines)
            log.exception("audit log %s: %d entries not written", self.path, len(lines))
            return
        self._unwritten.clear()
        self.last_error = None

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


def _line(entry: Mapping[str, Any]) -> str:
    """``entry`` as one JSON line: UTF-8 text, or ASCII with escapes when UTF-8 cannot hold
    it (a lone surrogate from a client), so that no entry is ever kept out of the file."""
    line = json.dumps(entry, ensure_ascii=False, separators=(",", ":"))
    try:
        line.encode("utf-8")
    except UnicodeEncodeError:
        return json.dumps(entry, ensure_ascii=True, separators=(",", ":"))
    return line
