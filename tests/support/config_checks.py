"""Reading what ``rc233-gateway check-config`` prints, and a serial port for its checks."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["problems_of", "pseudo_terminal"]


def problems_of(out: str, kind: str = "problem(s)") -> dict[str, str]:
    """The problems (or ``warning(s)``) printed, by key (the first of a key)."""
    found: dict[str, str] = {}
    inside = False
    for line in out.splitlines():
        if not line.startswith(" "):
            inside = line.endswith(f" {kind}")
            continue
        if inside:
            key, _, text = line.strip().partition(": ")
            found.setdefault(key, text)
    return found


@contextmanager
def pseudo_terminal() -> Iterator[str]:
    """The path of a terminal nobody reads: the slave end of a pseudo-terminal, as a serial
    port is one (a character device that ``isatty``)."""
    master, slave = os.openpty()
    try:
        yield os.ttyname(slave)
    finally:
        os.close(slave)
        os.close(master)
