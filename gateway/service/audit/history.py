"""Audit entries read back from the files: the pages older than what memory keeps.

Memory keeps the newest entries (``AuditRecord``'s ring, bounded by count and bytes); the
file and its rotated predecessors (``audit.jsonl``, ``audit.jsonl.1`` ... the oldest last)
keep every entry until rotation drops the oldest file. A page that reaches further back than
memory is read from them, in a worker thread, a line at a time (a file of 64 MiB is never read
whole): the newest ``limit`` from the ends of the files backwards, or the first ``limit``
after a seq or a time from the oldest file that can hold them forwards. A line that does not
parse (cut by hand, a torn tail before a restart) is skipped: ``rc233-gateway audit verify``
is the tool that names it.

Blocking: call it from a worker thread, never on the loop.
"""

from __future__ import annotations

import json
from collections import deque
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from gateway.service.audit.chain_file import rotated

__all__ = ["entries_after", "newest_entries"]

_CHUNK = 64 * 1024


def _files_newest_first(path: Path, keep: int) -> list[Path]:
    candidates = [path, *(rotated(path, index) for index in range(1, keep + 1))]
    return [p for p in candidates if p.exists()]


def _entry(line: bytes) -> dict[str, Any] | None:
    try:
        entry = json.loads(line)
    except ValueError:
        return None
    if not isinstance(entry, dict) or not isinstance(entry.get("seq"), int):
        return None
    return entry


def _lines_backwards(path: Path) -> Iterator[bytes]:
    """The whole lines of ``path``, the last first, read in chunks from the end."""
    with path.open("rb") as file:
        end = file.seek(0, 2)
        rest = b""
        while end > 0:
            start = max(0, end - _CHUNK)
            file.seek(start)
            chunk = file.read(end - start) + rest
            end = start
            lines = chunk.split(b"\n")
            rest = lines[0]  # may be the tail of a line that starts in the chunk before
            for line in reversed(lines[1:]):
                if line:
                    yield line
        if rest:
            yield rest


def newest_entries(path: Path, keep: int, limit: int) -> list[dict[str, Any]]:
    """The newest ``limit`` entries of the files, oldest first."""
    found: deque[dict[str, Any]] = deque()
    for file in _files_newest_first(path, keep):
        for line in _lines_backwards(file):
            entry = _entry(line)
            if entry is not None:
                found.appendleft(entry)
                if len(found) >= limit:
                    return list(found)
    return list(found)


def _first_entry(path: Path) -> dict[str, Any] | None:
    with path.open("rb") as file:
        for line in file:
            entry = _entry(line)
            if entry is not None:
                return entry
    return None


def entries_after(
    path: Path, keep: int, limit: int, *, since: int | None = None, stamp: str | None = None
) -> list[dict[str, Any]]:
    """The first ``limit`` entries with a seq over ``since`` and a time over ``stamp`` (ISO
    8601 UTC as entries write it), oldest first."""
    files = _files_newest_first(path, keep)
    # The newest file whose first entry is at or before the point holds the first entry
    # after it; older files hold nothing after it.
    start = len(files) - 1
    for index, file in enumerate(files):
        first = _first_entry(file)
        if first is not None and _at_or_before(first, since, stamp):
            start = index
            break
    out: list[dict[str, Any]] = []
    for file in reversed(files[: start + 1]):
        with file.open("rb") as lines:
            for line in lines:
                entry = _entry(line)
                if entry is None or _at_or_before(entry, since, stamp):
                    continue
                out.append(entry)
                if len(out) >= limit:
                    return out
    return out


def _at_or_before(entry: dict[str, Any], since: int | None, stamp: str | None) -> bool:
    if since is not None and entry["seq"] <= since:
        return True
    return stamp is not None and str(entry.get("time", "")) <= stamp
