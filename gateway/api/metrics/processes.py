"""What each gateway process holds, for ``/metrics``: memory, descriptors, asyncio tasks.

A gateway runs for months; a leak shows as a slope long before it shows as a failure. Each
scrape reads, from ``/proc`` (Linux; elsewhere the families are left out):

* ``rc233_process_resident_bytes{role, pid}``: resident memory (``VmRSS``);
* ``rc233_process_open_fds{role, pid}``: open descriptors;
* ``rc233_process_start_time_seconds{role, pid}``: when it started (Unix time), so that an
  alert on the slope of RSS can leave out the first hours, when the rings fill;
* ``rc233_process_asyncio_tasks{role="api"}``: tasks of the API process's event loop;

for the API process (``role="api"``) and every process below it (``role="worker"``: the
line workers, found through ``/proc/<pid>/task/<tid>/children``), so a sum over ``role`` is
the whole gateway. And what the long-lived structures of the API process keep
(``rc233_memory_kept_items`` / ``rc233_memory_kept_bytes{structure}``): the audit entries and
the feed's replay ring, each bounded by count and bytes (docs/performance.md, "Memory").

The reads are of procfs, which the kernel answers from memory: some 50 µs in all for a
gateway of a few processes, on the event loop like the rest of a scrape.
"""

from __future__ import annotations

import asyncio
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from gateway.api.metrics.exposition import Exposition

__all__ = ["ProcessFigures", "descendants", "process_exposition", "read_process"]

PROC = Path("/proc")


class ProcessFigures:
    """Resident bytes, open descriptors and start time (Unix) of one process."""

    def __init__(self, pid: int, rss: int, fds: int, started: float) -> None:
        self.pid, self.rss, self.fds, self.started = pid, rss, fds, started


def _boot_time() -> float:
    try:
        text = (PROC / "stat").read_text()
    except OSError:
        return 0.0
    return next((float(line.split()[1]) for line in text.splitlines()
                 if line.startswith("btime ")), 0.0)  # fmt: skip


_BOOT = _boot_time()
_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def read_process(pid: int) -> ProcessFigures | None:
    """The figures of ``pid`` from ``/proc`` (None: gone meanwhile, or no procfs)."""
    try:
        status = (PROC / str(pid) / "status").read_text()
        fds = len(os.listdir(PROC / str(pid) / "fd"))
        stat = (PROC / str(pid) / "stat").read_text()
    except OSError:
        return None
    # Field 22, after the command name in brackets (which may hold spaces): ticks since boot.
    started = _BOOT + int(stat.rsplit(")", 1)[1].split()[19]) / _TICKS
    # A zombie has no VmRSS line left: no memory.
    rss = next((int(line.split()[1]) * 1024 for line in status.splitlines()
                if line.startswith("VmRSS:")), 0)  # fmt: skip
    return ProcessFigures(pid, rss, fds, started)


def _children(pid: int) -> Iterator[int]:
    try:
        threads = os.listdir(PROC / str(pid) / "task")
    except OSError:
        return
    for tid in threads:
        try:
            text = (PROC / str(pid) / "task" / tid / "children").read_text()
        except OSError:
            continue
        yield from (int(word) for word in text.split())


def descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (children, theirs ...), nearest first."""
    found: list[int] = []
    todo = [pid]
    while todo:
        for child in _children(todo.pop()):
            if child not in found:
                found.append(child)
                todo.append(child)
    return found


def process_exposition(state: Any = None) -> str:
    """The families of the module docstring; ``state``: what holds the audit record and the
    feed (``audit``, ``feed``: the app's services), when there is one."""
    out = Exposition()
    me = os.getpid()
    figures = [(f, "api") for f in [read_process(me)] if f is not None]
    figures += [(f, "worker") for f in map(read_process, descendants(me)) if f is not None]
    if figures:
        out.family("rc233_process_resident_bytes", "gauge", "Resident memory of a process.")
        for f, role in figures:
            out.sample("rc233_process_resident_bytes", {"role": role, "pid": str(f.pid)}, f.rss)
        out.family("rc233_process_open_fds", "gauge", "Open file descriptors of a process.")
        for f, role in figures:
            out.sample("rc233_process_open_fds", {"role": role, "pid": str(f.pid)}, f.fds)
        out.family("rc233_process_start_time_seconds", "gauge", "When a process started.")
        for f, role in figures:
            labels = {"role": role, "pid": str(f.pid)}
            out.sample("rc233_process_start_time_seconds", labels, round(f.started, 2))
    try:
        tasks = len(asyncio.all_tasks())
    except RuntimeError:  # no running loop (a synchronous caller)
        tasks = None
    if tasks is not None:
        out.family("rc233_process_asyncio_tasks", "gauge", "Tasks of a process's event loop.")
        out.sample("rc233_process_asyncio_tasks", {"role": "api", "pid": str(me)}, tasks)
    _kept(out, state)
    return out.text() if out.lines else ""


def _kept(out: Exposition, state: Any) -> None:
    kept: dict[str, tuple[int, int]] = {}
    audit_kept = getattr(getattr(state, "audit", None), "kept", None)
    if isinstance(audit_kept, tuple):
        kept["audit"] = audit_kept
    replay_kept = getattr(getattr(state, "feed", None), "replay_kept", None)
    if isinstance(replay_kept, tuple):
        kept["feed_replay"] = replay_kept
    if not kept:
        return
    out.family("rc233_memory_kept_items", "gauge", "Items a bounded structure keeps in memory.")
    for name, (items, _) in kept.items():
        out.sample("rc233_memory_kept_items", {"structure": name}, items)
    out.family("rc233_memory_kept_bytes", "gauge", "Bytes (as measured) a bounded structure keeps.")
    for name, (_, size) in kept.items():
        out.sample("rc233_memory_kept_bytes", {"structure": name}, size)
