"""The audit file on disk: one JSON line an entry, chained by SHA-256, that cannot tear.

Each entry is numbered (``seq``) and carries ``prev``, the SHA-256 (hex) of the line before it
(the bytes of that line without its newline; ``GENESIS`` for the very first line), so that a
line removed, changed or put in another place breaks the chain where it happened
(``gateway.service.audit.verify``).

An entry goes out as one ``write()`` of one whole line on a file opened for appending. A write
that fails or writes part of the line (a full disk, a file-size limit) is cut back with
``ftruncate`` to the size the file had before it, so the next line never glues onto a torn
one; when even that fails, the next append first cuts the file back to its last newline.

At start the sequence and the chain go on from the file's tail (a torn last line, left by a
crash in the middle of a write, is cut off first); rotation by size keeps both: the file
becomes ``FILE.1`` (``FILE.1`` becomes ``FILE.2``, ...; ``keep`` of them are kept) and the
next line, the first of a new file, chains to the last line of ``FILE.1``.

Blocking: called from a worker thread (``gateway.service.audit.record``), never on the loop.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["GENESIS", "ChainFile", "RotationPolicy", "digest", "rotated"]

log = logging.getLogger("gateway.audit")

#: ``prev`` of the first line ever written
GENESIS = "0" * 64
#: how far back from the end the tail is searched for the last whole line
_TAIL_CHUNK = 64 * 1024


def digest(line: bytes) -> str:
    """The SHA-256 (hex) of ``line`` as written, without its newline."""
    return hashlib.sha256(line.rstrip(b"\n")).hexdigest()


def rotated(path: Path, index: int) -> Path:
    """The ``index``-th rotated file of ``path`` (``audit.jsonl.1`` is the newest)."""
    return path.with_name(f"{path.name}.{index}")


@dataclass(frozen=True)
class RotationPolicy:
    """Rotate when a line would take the file past ``max_bytes``; keep ``keep`` old files."""

    max_bytes: int = 64 * 1024 * 1024
    keep: int = 10


class ChainFile:
    """Appends chained, numbered lines to ``path`` (thread-safe; see the module docstring)."""

    def __init__(self, path: Path, rotation: RotationPolicy | None = None) -> None:
        self.path = path
        self.rotation = rotation or RotationPolicy()
        self._lock = threading.Lock()
        self._fd: int | None = None
        self._size = 0
        #: a cut-back failed: the file may end in a torn line, to be cut before the next line
        self._dirty = False
        self.last_seq, self.last_hash = _tail_of_history(path)

    # ------------------------------------------------------------------ writing

    def append(self, entry: dict[str, Any], *, fsync: bool) -> dict[str, Any]:
        """Number ``entry``, chain it, write it as one line (``fsync``: to the platter); the
        stored entry. ``OSError`` when the line could not be written whole (nothing of it
        stays in the file, and the sequence does not advance)."""
        with self._lock:
            stored = {"seq": self.last_seq + 1, "prev": self.last_hash, **entry}
            line = _encode(stored)
            fd = self._open()
            if self._size > 0 and self._size + len(line) > self.rotation.max_bytes:
                fd = self._rotate()
            before = self._size
            try:
                written = os.write(fd, line)
                if written != len(line):
                    raise OSError(f"wrote {written} of {len(line)} bytes (disk full?)")
                if fsync:
                    os.fsync(fd)
            except OSError:
                self._cut_back(fd, before)
                raise
            self._size = before + len(line)
            self.last_seq = stored["seq"]
            self.last_hash = digest(line)
            return stored

    def close(self) -> None:
        """Close the file (the next append opens it again)."""
        with self._lock:
            self._close()

    # ------------------------------------------------------------------ helpers

    def _open(self) -> int:
        if self._fd is not None and not self._still_the_file(self._fd):
            # Moved or removed under us (by hand, by an outside rotation): lines written to
            # the old inode would be lost to readers of ``path``; write to ``path`` again.
            log.warning("audit file %s was moved or removed: opening it again", self.path)
            self._close()
        if self._fd is None:
            fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o640)
            self._fd, self._size = fd, os.fstat(fd).st_size
        if self._dirty:
            self._repair(self._fd)
        return self._fd

    def _still_the_file(self, fd: int) -> bool:
        try:
            named = os.stat(self.path)
        except OSError:
            return False
        held = os.fstat(fd)
        return (named.st_dev, named.st_ino) == (held.st_dev, held.st_ino)

    def _close(self) -> None:
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.close(self._fd)
            self._fd = None

    def _cut_back(self, fd: int, size: int) -> None:
        """Remove what a failed write left (part of a line) so nothing glues onto it."""
        try:
            os.ftruncate(fd, size)
        except OSError:
            log.exception("audit file %s: a torn line could not be cut off yet", self.path)
            self._dirty = True
            self._close()
        else:
            self._size = size

    def _repair(self, fd: int) -> None:
        size = os.fstat(fd).st_size
        keep = _last_newline_end(self.path, size)
        if keep != size:
            os.ftruncate(fd, keep)
            log.warning("audit file %s: cut a torn line (%d bytes)", self.path, size - keep)
        self._size, self._dirty = keep, False

    def _rotate(self) -> int:
        self._close()
        keep = max(self.rotation.keep, 1)
        with contextlib.suppress(FileNotFoundError):
            rotated(self.path, keep).unlink()
        for index in range(keep - 1, 0, -1):
            with contextlib.suppress(FileNotFoundError):
                rotated(self.path, index).rename(rotated(self.path, index + 1))
        self.path.rename(rotated(self.path, 1))
        return self._open()


def _encode(entry: dict[str, Any]) -> bytes:
    """One JSON line: UTF-8, or ASCII escapes where UTF-8 cannot hold a character (a lone
    surrogate from a client), so that no entry is kept out of the file."""
    text = json.dumps(entry, ensure_ascii=False, separators=(",", ":"))
    try:
        return (text + "\n").encode("utf-8")
    except UnicodeEncodeError:
        return (json.dumps(entry, ensure_ascii=True, separators=(",", ":")) + "\n").encode()


def _last_newline_end(path: Path, size: int) -> int:
    """The size of ``path`` up to and with its last newline (0: none)."""
    with path.open("rb") as file:
        end = size
        while end > 0:
            start = max(0, end - _TAIL_CHUNK)
            file.seek(start)
            chunk = file.read(end - start)
            found = chunk.rfind(b"\n")
            if found >= 0:
                return start + found + 1
            end = start
    return 0


def _tail_of_history(path: Path) -> tuple[int, str]:
    """(last seq, SHA-256 of the last line) of ``path``, or of its newest rotated file when
    it is empty or missing; a torn last line is cut off first. (0, GENESIS): no history."""
    for candidate in (path, rotated(path, 1)):
        try:
            size = candidate.stat().st_size
        except FileNotFoundError:
            continue
        keep = _last_newline_end(candidate, size)
        if keep != size and candidate == path:
            with candidate.open("r+b") as file:
                file.truncate(keep)
            log.warning("audit file %s: cut a torn last line (%d bytes)", path, size - keep)
        if keep == 0:
            continue
        with candidate.open("rb") as file:
            file.seek(max(0, keep - _TAIL_CHUNK))
            lines = file.read(keep - max(0, keep - _TAIL_CHUNK)).split(b"\n")[:-1]
        for back, line in enumerate(reversed(lines)):
            seq = _seq_of(line)
            if seq is not None:  # lines after it that do not parse still took their numbers
                return seq + back, digest(lines[-1])
        raise OSError(f"{candidate}: its last lines hold no audit sequence number")
    return 0, GENESIS


def _seq_of(line: bytes) -> int | None:
    try:
        seq = json.loads(line).get("seq")
    except (ValueError, AttributeError):
        return None
    return seq if isinstance(seq, int) and not isinstance(seq, bool) else None
