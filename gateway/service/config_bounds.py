"""The configuration file read with bounds, before the TOML parser sees it.

A configuration is written by hand and may be anything: a file copied over the wrong one, a
binary, a generated file gone wrong. Python's ``tomllib`` is not made for hostile input: a
dotted key of a few thousand parts (``a.a.a...``) costs it time and memory that grow faster
than the square of the key (24 GB for 200 KB), and arrays or inline tables nested some
hundreds deep exhaust the interpreter's stack (a ``RecursionError`` traceback). So the file
is checked here first, in one linear pass over at most ``max_bytes``:

* its size (a cell's file is a few KB; 1 MiB is far above any real one), read from the open
  file, so a device or a pipe given as the file is refused rather than read without end;
* a NUL byte: a binary file, named as such (TOML text holds no NUL);
* its encoding: UTF-8 (TOML's), an invalid byte named with its line and column;
* nesting: arrays, inline tables and table headers at most ``max_depth`` levels deep;
* keys: at most ``max_key_parts`` dotted parts (``loops.controllers.axes`` has 3).

The scan knows TOML's strings and comments (brackets and dots inside them do not count), so
no valid configuration is refused by it. Whatever it lets through, ``tomllib`` parses in
time linear in the file. ``listed`` caps a list of problems for people to read.
"""

from __future__ import annotations

import os
import re
import stat
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["MAX_LISTED", "FileBounds", "UnreadableConfig", "listed", "read_toml", "scan_toml"]

#: How many problems are listed; the rest are counted (a file of 10,000 bad keys is one mistake)
MAX_LISTED = 50


class UnreadableConfig(ValueError):
    """The file cannot be taken as a configuration; the message says why, without the path."""


@dataclass(frozen=True)
class FileBounds:
    """What a configuration file may be, at most."""

    max_bytes: int = 1 << 20
    max_depth: int = 32
    max_key_parts: int = 32


# What the scan stops at: string and comment openers, brackets, and what ends a dotted key.
_SPECIAL = re.compile(r"[\"'#\[\]{}.=,\n]")
# The rest of a string after its opening quote(s), in the unrolled form (linear, no backtracking
# blow-up). A single-line string ends at the end of the line at the latest (TOML: it must not
# span lines; the parser says so).
_BASIC_REST = re.compile(r'[^"\\\n]*(?:\\.[^"\\\n]*)*\\?(?:"|(?=\n)|\Z)')
_LITERAL_REST = re.compile(r"[^'\n]*(?:'|(?=\n)|\Z)")
_ML_BASIC_REST = re.compile(r'[^"\\]*(?:(?:\\.|"(?!""))[^"\\]*)*\\?(?:""""{0,2}|\Z)', re.S)
_ML_LITERAL_REST = re.compile(r"[^']*(?:'(?!'')[^']*)*(?:''''{0,2}|\Z)")
_LINE_END = re.compile(r"[^\n]*")


def _line_col(text: str, offset: int) -> tuple[int, int]:
    line = text.count("\n", 0, offset) + 1
    return line, offset - (text.rfind("\n", 0, offset) + 1) + 1


def scan_toml(text: str, bounds: FileBounds = FileBounds()) -> None:
    """``UnreadableConfig`` if ``text`` nests deeper or has a longer dotted key than
    ``bounds`` allow; one pass, stopping at the first excess."""
    depth = 0
    dots = 0  # dots since the last thing that ends a key: a key of ``dots + 1`` parts
    pos = 0
    while (found := _SPECIAL.search(text, pos)) is not None:
        char = found.group()
        pos = found.end()
        if char == '"' or char == "'":
            triple = text.startswith(char * 2, pos)
            if triple:
                rest = _ML_BASIC_REST if char == '"' else _ML_LITERAL_REST
                pos += 2
            else:
                rest = _BASIC_REST if char == '"' else _LITERAL_REST
            end = rest.match(text, pos)
            pos = end.end() if end is not None else pos  # each form ends at a line or the text
        elif char == "#":
            end = _LINE_END.match(text, pos)
            pos = end.end() if end is not None else pos
        elif char == ".":
            dots += 1
            if dots >= bounds.max_key_parts:
                line, col = _line_col(text, found.start())
                raise UnreadableConfig(
                    f"line {line}, column {col}: a dotted key of more than "
                    f"{bounds.max_key_parts} parts (at most {bounds.max_key_parts})"
                )
        else:
            dots = 0
            if char == "[" or char == "{":
                depth += 1
                if depth > bounds.max_depth:
                    line, col = _line_col(text, found.start())
                    raise UnreadableConfig(
                        f"line {line}, column {col}: nested more than {bounds.max_depth} "
                        f"levels deep (arrays, inline tables; at most {bounds.max_depth})"
                    )
            elif char == "]" or char == "}":
                depth = max(0, depth - 1)  # unbalanced: the parser names it


def decode(raw: bytes, bounds: FileBounds = FileBounds()) -> str:
    """``raw`` as the text of a configuration: ``UnreadableConfig`` for too many bytes, a
    binary file or invalid UTF-8, each named as such."""
    if len(raw) > bounds.max_bytes:
        raise UnreadableConfig(
            f"larger than {bounds.max_bytes} bytes: not a configuration (a cell's file is a few KB)"
        )
    nul = raw.find(b"\0")
    if nul >= 0:
        raise UnreadableConfig(f"a binary file (a NUL byte at offset {nul}), not TOML text")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        good = raw[: exc.start].decode("utf-8")
        line, col = _line_col(good, len(good))
        raise UnreadableConfig(
            f"not UTF-8: invalid byte 0x{raw[exc.start]:02x} at line {line}, column {col} "
            f"(offset {exc.start}); TOML files are UTF-8"
        ) from None


def _read_bytes(path: Path, limit: int) -> bytes:
    """At most ``limit`` bytes of the regular file ``path`` (opened without blocking, so a
    pipe or a device given as the file is refused, not waited on)."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | getattr(os, "O_CLOEXEC", 0))
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise UnreadableConfig("not a regular file")
        chunks: list[bytes] = []
        left = limit
        while left > 0 and (chunk := os.read(fd, min(left, 1 << 16))):
            chunks.append(chunk)
            left -= len(chunk)
        return b"".join(chunks)
    finally:
        os.close(fd)


def read_toml(path: Path, bounds: FileBounds = FileBounds()) -> dict[str, Any]:
    """The TOML document of ``path``, read within ``bounds``.

    ``OSError`` if the file cannot be read; ``UnreadableConfig`` (saying why: size, binary,
    encoding, nesting, key length, TOML syntax) if it is no configuration.
    """
    text = decode(_read_bytes(path, bounds.max_bytes + 1), bounds)
    scan_toml(text, bounds)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise UnreadableConfig(f"not valid TOML ({exc})") from None
    except RecursionError:  # the scan bounds nesting; kept as a last guard, never a traceback
        raise UnreadableConfig("nested too deeply") from None


def listed(problems: Sequence[str], limit: int = MAX_LISTED) -> list[str]:
    """The first ``limit`` of ``problems``, then one line counting the rest."""
    if len(problems) <= limit:
        return list(problems)
    return [*problems[:limit], f"... and {len(problems) - limit} more problem(s)"]
