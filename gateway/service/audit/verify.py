"""Checking audit files: every line whole JSON, numbered one after the other, chained.

``verify(paths)`` reads the files given, oldest first (``audit.jsonl.2 audit.jsonl.1
audit.jsonl`` after rotation), as one history and names the first break: a line that is not
JSON or not whole (no newline at the end), a ``seq`` that does not follow the one before, a
``prev`` that is not the SHA-256 of the line before. The first line of the first file is
checked against nothing before it unless it is the very first line (``prev`` ``GENESIS``,
``seq`` 1): a file that starts after a rotation starts where its predecessor ended.
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from gateway.service.audit.chain_file import GENESIS, digest

__all__ = ["Break", "Verified", "verify"]


@dataclass(frozen=True)
class Break:
    """Where the history breaks first: the file, its line number (from 1) and why."""

    path: Path
    line: int
    reason: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: {self.reason}"


@dataclass(frozen=True)
class Verified:
    """What was checked: the lines, the first and last ``seq``, and the first break."""

    lines: int
    first_seq: int | None
    last_seq: int | None
    broken: Break | None


def _lines(path: Path) -> Iterator[tuple[int, bytes, bool]]:
    """(number, bytes without the newline, whole) of each line of ``path``."""
    with path.open("rb") as file:
        for number, raw in enumerate(file, start=1):
            yield number, raw.rstrip(b"\n"), raw.endswith(b"\n")


def verify(paths: Sequence[Path]) -> Verified:
    """Check ``paths`` (oldest first) as one history (module docstring)."""
    count, first, last_seq, last_hash = 0, None, None, None
    for path in paths:
        for number, line, whole in _lines(path):
            count += 1
            if not whole:
                return Verified(
                    count, first, last_seq, Break(path, number, "a torn line (no newline)")
                )
            try:
                entry = json.loads(line)
            except ValueError as exc:
                return Verified(count, first, last_seq, Break(path, number, f"not JSON: {exc}"))
            seq = entry.get("seq") if isinstance(entry, dict) else None
            prev = entry.get("prev") if isinstance(entry, dict) else None
            if not isinstance(seq, int) or isinstance(seq, bool) or not isinstance(prev, str):
                reason = "no seq or no prev: not an audit entry"
                return Verified(count, first, last_seq, Break(path, number, reason))
            if last_seq is None:
                if prev == GENESIS and seq != 1:
                    reason = f"seq {seq}: the first entry ever (prev {GENESIS[:8]}...) is seq 1"
                    return Verified(count, first, last_seq, Break(path, number, reason))
                first = seq
            else:
                if seq != last_seq + 1:
                    reason = f"seq {seq} follows seq {last_seq} (expected {last_seq + 1})"
                    return Verified(count, first, last_seq, Break(path, number, reason))
                if prev != last_hash:
                    reason = (
                        f"seq {seq}: prev {prev[:16]}... is not the SHA-256 of the line before "
                        f"({str(last_hash)[:16]}...): a line was changed, removed or inserted"
                    )
                    return Verified(count, first, last_seq, Break(path, number, reason))
            last_seq, last_hash = seq, digest(line)
    return Verified(count, first, last_seq, None)
