"""``rc233-gateway audit verify FILE...``: check audit files after the fact, offline.

Reads the files given, oldest first, as one history (``gateway.service.audit.verify``): each
line whole JSON, ``seq`` one after the other, ``prev`` the SHA-256 of the line before. With
``--rotated`` the rotated files of FILE (``FILE.n`` ... ``FILE.1``) are read before it.

Exit codes: 0 the history holds; 1 it breaks (the first break is printed: file, line, why);
2 a file cannot be read.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rc233-gateway audit verify",
        description="Check the chain (SHA-256 of each previous line) and the sequence of "
        "audit files; name the first break.",
    )
    parser.add_argument("files", nargs="+", type=Path, help="audit files, oldest first")
    parser.add_argument(
        "--rotated",
        action="store_true",
        help="read the rotated files of each FILE (FILE.n ... FILE.1) before it",
    )
    return parser


def _with_rotated(path: Path) -> list[Path]:
    from gateway.service.audit.chain_file import rotated

    older: list[Path] = []
    index = 1
    while rotated(path, index).exists():
        older.append(rotated(path, index))
        index += 1
    return [*reversed(older), path]


def main(argv: Sequence[str]) -> int:
    """Verify the files of ``argv``; the exit code (module docstring)."""
    from gateway.service.audit.verify import verify

    args = _parser().parse_args(list(argv))
    paths: list[Path] = []
    for path in args.files:
        paths.extend(_with_rotated(path) if args.rotated else [path])
    try:
        checked = verify(paths)
    except OSError as exc:
        print(f"rc233-gateway audit verify: cannot read: {exc}", file=sys.stderr)
        return 2
    if checked.broken is not None:
        print(
            f"broken: {checked.broken} (after {checked.lines - 1} good lines)",
            file=sys.stderr,
        )
        return 1
    span = f"seq {checked.first_seq}..{checked.last_seq}" if checked.lines else "empty"
    print(f"ok: {checked.lines} entries, {span}, chain and sequence hold")
    return 0
