"""RC233_TRACEMALLOC: a serve that shows what grew, dump after dump."""

from __future__ import annotations

import os
import signal
import tracemalloc
from pathlib import Path

import pytest

from gateway.heap_trace import ENV, ENV_OUT, install_from_env


def test_off_unless_asked() -> None:
    assert install_from_env({}) is None
    assert install_from_env({ENV: "0"}) is None


def test_a_setting_that_is_no_number_is_refused_naming_the_variable() -> None:
    with pytest.raises(SystemExit, match=f"{ENV} must be a number of frames"):
        install_from_env({ENV: "yes"})


def test_each_dump_names_the_lines_that_grew_since_the_one_before(tmp_path: Path) -> None:
    out = tmp_path / "heap.txt"
    before = signal.getsignal(signal.SIGUSR2)
    tracer = install_from_env({ENV: "1", ENV_OUT: str(out)}, role="line worker")
    try:
        assert tracer is not None and tracemalloc.is_tracing()
        assert signal.getsignal(signal.SIGUSR2) == tracer.on_signal
        kept = [bytes(1000) + bytes([n % 256]) for n in range(2_000)]  # some 2 MB here
        tracer.dump()
        first = out.read_text()
        # serve and its workers append to one file: each dump says whose heap it is
        assert f"heap dump 1 of line worker (pid {os.getpid()})" in first
        top = first.splitlines()[1]
        assert f"{Path(__file__).name}:" in top  # the line above is the largest growth
        tracer.dump()  # nothing of this test grew since
        second = out.read_text()[len(first) :]
        assert "heap dump 2" in second
        assert Path(__file__).name not in second.splitlines()[1]
        assert len(kept) == 2_000
    finally:
        tracemalloc.stop()
        signal.signal(signal.SIGUSR2, before)
