"""The audit record: entries written ahead of what they record, the newest kept in memory.

Two ways in:

* ``await write_ahead(entry, motion=...)`` for anything that acts, before its first frame: it
  returns once the line is in the file (written, and ``fsync``-ed for motion unless
  ``fsync`` says otherwise), with the entry's ``seq`` for the outcome entry to name. When the
  line cannot be written it raises ``AuditUnavailable`` (the caller refuses the request and
  sends nothing), except for a stop (``stop=True``): a stop always passes; its entry is
  logged at once and queued, to reach the file as soon as the file takes writes again.
* ``record(entry)`` for outcomes and what no request made (a key switch, an operation
  resolved): queued and written by a writer task in a worker thread.

The file itself is ``ChainFile`` (numbered, chained, never torn, rotated by size). While a
write fails, the record is not ``healthy`` (``/readyz`` answers 503) and the writer tries
again every ``retry_interval`` seconds by itself, queued entries first, then an entry saying
the file takes writes again (how long it did not, and how many requests were refused), so
readiness comes back without waiting for a request.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import threading
from collections import deque
from collections.abc import Awaitable, Iterable, Mapping
from datetime import UTC, datetime
from enum import StrEnum
from pathlib import Path
from typing import Any, Protocol

from gateway.errors import ServiceError
from gateway.rings import BoundedRing
from gateway.service.audit.bounds import bounded
from gateway.service.audit.chain_file import ChainFile, RotationPolicy
from gateway.service.audit.history import entries_after, newest_entries

__all__ = [
    "MEMORY",
    "MEMORY_BYTES",
    "PAGE_LIMIT",
    "QUEUE",
    "AuditRecord",
    "AuditUnavailable",
    "FsyncPolicy",
    "utc_now",
]

log = logging.getLogger("gateway.audit")

#: entries kept in memory for ``GET /api/v1/audit``: the pages asked most (the newest), served
#: without reading the file; older pages are read from the file (``history``)
MEMORY = 1_000
#: bytes (as JSON text) of the entries kept in memory: an entry is 300 bytes or, with every
#: value at ``VALUE_LIMIT``, tens of kilobytes, and the count alone would not bound memory
MEMORY_BYTES = 2 * 1024 * 1024
#: entries one page may hold (``limit``)
PAGE_LIMIT = 10_000
#: entries queued at most while the file fails (the oldest dropped first, counted)
QUEUE = 10_000


def _stamp(moment: datetime) -> str:
    """``moment`` as entries write their ``time`` (ISO 8601 UTC, ms, ``Z``)."""
    return moment.astimezone(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def _json_size(entry: dict[str, Any]) -> int:
    """The bytes of an entry as JSON text (what the ring's byte bound counts)."""
    return len(json.dumps(entry, ensure_ascii=False, default=str))


def utc_now() -> str:
    """Now as ISO 8601 UTC with milliseconds (``2025-01-31T12:00:00.000Z``)."""
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


class FsyncPolicy(StrEnum):
    """Which entries are forced to the disk (``fsync``) before the call returns."""

    MOTION = "motion"  # the entries written ahead of motion (the default)
    ACTING = "acting"  # every entry written ahead of something that acts
    ALL = "all"  # every entry, outcomes too
    NONE = "none"  # none: written and flushed to the OS only


class WriteAhead(Protocol):
    """``AuditRecord.write_ahead`` as a face sees it: the entry on disk before acting."""

    def __call__(
        self, entry: Mapping[str, Any], *, motion: bool, stop: bool = False
    ) -> Awaitable[int | None]:
        """The entry's seq (None: a stop's entry queued); raises when it cannot be written."""


class AuditUnavailable(ServiceError):
    """The audit entry of a request that acts could not be written: nothing was sent."""

    retry_after = 1


class AuditRecord:
    """The audit record of the gateway (module docstring); ``path`` None: memory only."""

    def __init__(
        self,
        path: Path | None = None,
        *,
        memory: int = MEMORY,
        memory_bytes: int = MEMORY_BYTES,
        queue: int = QUEUE,
        rotation: RotationPolicy | None = None,
        fsync: FsyncPolicy = FsyncPolicy.MOTION,
        retry_interval: float = 1.0,
    ) -> None:
        self.path = path
        self.fsync = fsync
        self.retry_interval = retry_interval
        self._ring: BoundedRing[dict[str, Any]] = BoundedRing(memory, memory_bytes, _json_size)
        self._queue: deque[dict[str, Any]] = deque()
        self._queue_limit = queue
        self.rotation = rotation or RotationPolicy()
        self._drain_lock = threading.Lock()
        self._wake: asyncio.Event | None = None
        self._tried: asyncio.Event | None = None  # set after each pass of the writer
        self._writer: asyncio.Task[None] | None = None
        self._seq = 0  # memory-only numbering
        self._file: ChainFile | None = None
        #: writes to the file that failed (each try counts, the writer's retries too)
        self.write_errors = 0
        #: requests refused because their entry could not be written
        self.refused = 0
        #: entries dropped because the queue of unwritten ones was full
        self.dropped = 0
        #: why the last write failed (None: it did not)
        self.last_error: str | None = None
        self._failing_since: str | None = None
        if path is not None:
            try:
                self._file = ChainFile(path, self.rotation)
            except OSError as exc:  # the writer retries; requests that act are refused
                self._failed(exc, 0)

    # ------------------------------------------------------------------ reading

    @property
    def healthy(self) -> bool:
        """False while the last write to the file failed (``/readyz`` says so)."""
        return self.last_error is None

    @property
    def last_seq(self) -> int:
        """The number of the newest entry written (0: none yet, ever)."""
        return self._file.last_seq if self._file is not None else self._seq

    def entries(
        self, *, limit: int = 100, since: int | None = None, after: datetime | None = None
    ) -> list[dict[str, Any]]:
        """Entries oldest first: the first ``limit`` after ``since`` (a seq) or ``after`` (a
        time) when given, else the newest ``limit``."""
        selected: Iterable[dict[str, Any]] = list(self._ring)
        if since is not None:
            selected = (e for e in selected if e["seq"] > since)
        if after is not None:
            stamp = _stamp(after)
            selected = (e for e in selected if e["time"] > stamp)
        found = list(selected)
        if since is None and after is None:
            return found[-limit:]
        return found[:limit]

    @property
    def kept(self) -> tuple[int, int]:
        """Entries in memory and their bytes (as JSON text)."""
        return len(self._ring), self._ring.nbytes

    async def page(
        self, *, limit: int = 100, since: int | None = None, after: datetime | None = None
    ) -> list[dict[str, Any]]:
        """What ``entries`` answers, over every entry the files still hold: from memory when
        it holds the page, else read from the files in a worker thread."""
        if self.path is None or self._in_ring(limit, since, after):
            return self.entries(limit=limit, since=since, after=after)
        path, keep = self.path, max(self.rotation.keep, 1)
        if since is None and after is None:
            return await asyncio.to_thread(newest_entries, path, keep, limit)
        stamp = None if after is None else _stamp(after)
        return await asyncio.to_thread(entries_after, path, keep, limit, since=since, stamp=stamp)

    def _in_ring(self, limit: int, since: int | None, after: datetime | None) -> bool:
        if not self._ring:
            return self.last_seq == 0
        oldest = self._ring[0]
        if oldest["seq"] <= 1:  # memory holds every entry there ever was
            return True
        if since is None and after is None:
            return limit <= len(self._ring)
        if since is not None and since < oldest["seq"] - 1:
            return False
        return after is None or str(oldest.get("time", "")) <= _stamp(after)

    # ------------------------------------------------------------------ writing

    def fsync_for(self, *, motion: bool, ahead: bool) -> bool:
        """Whether an entry (of motion; written ahead) is forced to the disk."""
        if self.fsync is FsyncPolicy.ALL:
            return True
        if self.fsync is FsyncPolicy.ACTING:
            return ahead
        return self.fsync is FsyncPolicy.MOTION and motion and ahead

    async def write_ahead(
        self, entry: Mapping[str, Any], *, motion: bool, stop: bool = False
    ) -> int | None:
        """Write ``entry`` now, before what it records acts; its ``seq`` (None: a stop whose
        entry is queued). ``AuditUnavailable`` when it cannot be written."""
        if self._file is None and self.path is None:
            return int(self._in_memory(entry)["seq"])
        self._start_writer()
        # A stop never waits for the platter (DESIGN invariant 8: its latency is the line's).
        fsync = self.fsync_for(motion=motion, ahead=True) and not stop
        try:
            stored = await asyncio.to_thread(self._ahead, bounded(entry), fsync)
        except OSError as exc:
            self._failed(exc, 1)
            if stop:
                # A stop is never held back by the record: it goes out, and its entry follows.
                log.error("audit log: a stop passes unrecorded for now, queued: %r", entry)
                self.record({**entry, "late": True})
                return None
            self.refused += 1
            raise AuditUnavailable(
                f"the audit entry could not be written ({self.last_error}); nothing was sent"
            ) from None
        if self._failing_since is None:
            self.last_error = None
        elif self._wake is not None:
            self._wake.set()  # the writer says in the file that it takes writes again
        return int(stored["seq"])

    def start(self) -> None:
        """Start the writer now (on the running loop): it retries a file that failed already
        at start, so readiness follows the file without waiting for a request."""
        if self.path is not None:
            self._start_writer()

    async def until_healthy(self) -> None:
        """Return once the file takes writes again, by the writer's own retries (no request
        needed); at once when it does already."""
        while not self.healthy:
            self._start_writer()
            if self._tried is None:
                await self.flush()  # no loop task to wait for: try now
                continue
            self._tried.clear()
            await self._tried.wait()

    def record(self, entry: Mapping[str, Any]) -> None:
        """Queue ``entry`` for the file (memory only: number and keep it now)."""
        if self.path is None:
            self._in_memory(entry)
            return
        if len(self._queue) >= self._queue_limit:
            self._queue.popleft()
            self.dropped += 1
            if self.dropped == 1 or self.dropped % 1000 == 0:  # loud, not a flood of lines
                log.error("audit log: queue of unwritten entries full: %d dropped", self.dropped)
        self._queue.append(bounded(entry))
        self._start_writer()
        if self._wake is not None:
            self._wake.set()

    async def flush(self) -> None:
        """Try to write every entry queued so far (those that fail stay queued)."""
        if self.path is not None:
            await asyncio.to_thread(self._drain)

    async def close(self) -> None:
        """Write what is queued, then stop the writer and close the file."""
        await self.flush()
        if self._writer is not None:
            self._writer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._writer
            self._writer = None
        if self._file is not None:
            self._file.close()

    # ------------------------------------------------------------------ helpers

    def _in_memory(self, entry: Mapping[str, Any]) -> dict[str, Any]:
        self._seq += 1
        stored = {"seq": self._seq, **bounded(entry)}
        self._ring.append(stored)
        return stored

    def _append(self, entry: dict[str, Any], fsync: bool) -> dict[str, Any]:
        """Blocking: one line to the file (a worker thread)."""
        if self._file is None:
            assert self.path is not None
            self._file = ChainFile(self.path, self.rotation)
        stored = self._file.append(entry, fsync=fsync)
        self._ring.append(stored)
        return stored

    def _ahead(self, entry: dict[str, Any], fsync: bool) -> dict[str, Any]:
        """Blocking: what is queued, then ``entry``, so the file keeps the order of events."""
        with self._drain_lock:
            while self._queue:
                self._append(self._queue[0], False)
                self._queue.popleft()
            return self._append(entry, fsync)

    def _drain(self) -> None:
        """Blocking: the queued entries to the file, in order; on a failure they stay."""
        with self._drain_lock:
            fsync = self.fsync_for(motion=False, ahead=False)
            while self._queue:
                entry = self._queue[0]
                try:
                    self._append(entry, fsync)
                except OSError as exc:
                    self._failed(exc, 1)
                    return
                self._queue.popleft()
            if self._failing_since is not None:
                self._write_resumed()
            else:
                self.last_error = None

    def _write_resumed(self) -> None:
        note = {
            "time": utc_now(),
            "method": "AUDIT",
            "path": str(self.path),
            "event": "audit_resumed",
            "failed_since": self._failing_since,
            "refused": self.refused,
            "cause": self.last_error,
        }
        try:
            self._append(note, self.fsync_for(motion=False, ahead=False))
        except OSError as exc:
            self._failed(exc, 0)
            return
        log.warning(
            "audit log %s takes writes again (failing since %s)", self.path, note["failed_since"]
        )
        self.last_error = self._failing_since = None

    def _failed(self, exc: OSError, lines: int) -> None:
        self.write_errors += lines
        first = self.last_error is None
        self.last_error = f"{self.path}: {exc}"
        if self._failing_since is None:
            self._failing_since = utc_now()
        if first:
            log.error("audit log %s cannot be written: %s", self.path, exc)

    def _start_writer(self) -> None:
        if self._writer is not None and not self._writer.done():
            return
        try:
            asyncio.get_running_loop()
        except RuntimeError:
            return  # no loop (a synchronous caller): ``flush``/``close`` write the queue
        self._wake, self._tried = asyncio.Event(), asyncio.Event()
        self._writer = asyncio.create_task(self._write_forever(self._wake), name="audit-writer")

    async def _write_forever(self, wake: asyncio.Event) -> None:
        while True:
            if self.healthy and not self._queue:
                await wake.wait()
            else:  # failing: try again by itself, without waiting for a request
                # asyncio.timeout, not wait_for: 3.11's wait_for can swallow a cancel that
                # meets a wake-up, and the writer would outlive ``close``.
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(self.retry_interval):
                        await wake.wait()
            wake.clear()
            try:
                await asyncio.to_thread(self._drain)
            except Exception:  # whatever it is, the writer lives
                log.exception("audit log %s: the writer failed", self.path)
            if self._tried is not None:
                self._tried.set()
