"""A debug switch that shows what grows in a long-running gateway: ``RC233_TRACEMALLOC=1``.

With the variable set (to the number of frames a traceback keeps, ``1`` meaning 1, at most
25), the process starts ``tracemalloc`` before anything else is imported, takes a first
snapshot, and on every ``SIGUSR2`` (and once at exit) writes the lines that allocated most
since the previous snapshot, largest growth first, to ``RC233_TRACEMALLOC_OUT`` (a file it
appends to) or standard error. ``serve`` and its line workers (which inherit the variable) each
trace their own heap; every dump names its process (role and PID), so one file holds them all::

    RC233_TRACEMALLOC=1 rc233-gateway serve --config cell.toml &
    pkill -USR2 -g $(ps -o pgid= $!)   # some minutes later, again: the growth since the last

Tracing costs CPU and memory (some 30 % more of both): a diagnostic run, never on site.
Taking a snapshot blocks the process for a moment (tens of milliseconds): the handler runs on
the main thread, between two bytecodes of whatever the event loop runs then.
"""

from __future__ import annotations

import atexit
import os
import signal
import sys
import time
import tracemalloc
from types import FrameType

__all__ = ["HeapTracer", "install_from_env"]

ENV = "RC233_TRACEMALLOC"
ENV_OUT = "RC233_TRACEMALLOC_OUT"
TOP = 25  # lines a dump shows


class HeapTracer:
    """Snapshots of the traced heap; each ``dump`` writes the growth since the previous one."""

    def __init__(self, out: str | None, frames: int = 1, role: str = "serve") -> None:
        self._out = out
        self._role = role
        if not tracemalloc.is_tracing():
            tracemalloc.start(frames)
        self._started = time.monotonic()
        self._previous = self._snapshot()
        self._count = 0

    @staticmethod
    def _snapshot() -> tracemalloc.Snapshot:
        # The tracer's own bookkeeping is not what the gateway grows.
        return tracemalloc.take_snapshot().filter_traces(
            (tracemalloc.Filter(False, tracemalloc.__file__), tracemalloc.Filter(False, __file__))
        )

    def dump(self) -> str:
        """The growth since the previous dump, as text, also written where configured ("":
        tracing was stopped meanwhile)."""
        if not tracemalloc.is_tracing():
            return ""
        current = self._snapshot()
        stats = current.compare_to(self._previous, "lineno")
        self._previous = current
        self._count += 1
        traced, peak = tracemalloc.get_traced_memory()
        lines = [
            f"--- heap dump {self._count} of {self._role} (pid {os.getpid()}) at "
            f"{time.monotonic() - self._started:.0f} s: "
            f"traced {traced / 1e6:.1f} MB (peak {peak / 1e6:.1f} MB), top growth since the "
            "previous dump"
        ]
        lines += [str(stat) for stat in stats[:TOP]]
        text = "\n".join(lines) + "\n"
        self._write(text)
        return text

    def _write(self, text: str) -> None:
        if self._out is None:
            sys.stderr.write(text)
            sys.stderr.flush()
            return
        with open(self._out, "a", encoding="utf-8") as file:
            file.write(text)

    def on_signal(self, _signum: int, _frame: FrameType | None) -> None:
        """The ``SIGUSR2`` handler."""
        self.dump()


def install_from_env(
    environ: dict[str, str] | None = None, role: str = "serve"
) -> HeapTracer | None:
    """Start tracing ``role``'s process when ``RC233_TRACEMALLOC`` asks for it; ``None`` when
    it does not."""
    env = os.environ if environ is None else environ
    setting = env.get(ENV, "").strip()
    if setting in ("", "0"):
        return None
    try:
        frames = min(max(int(setting), 1), 25)
    except ValueError:
        raise SystemExit(f"{ENV} must be a number of frames (1-25), not {setting!r}") from None
    tracer = HeapTracer(env.get(ENV_OUT) or None, frames, role)
    signal.signal(signal.SIGUSR2, tracer.on_signal)
    atexit.register(tracer.dump)
    return tracer
