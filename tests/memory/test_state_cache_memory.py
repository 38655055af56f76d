"""The state cache holds its records, not their history: replies that keep changing the
records of the same controllers leave its memory where it was."""

from __future__ import annotations

import gc
import tracemalloc

from gateway.bus.state import StateCache


def _polls(state: StateCache, first: int, count: int) -> None:
    """Replies of three controllers every 50 ms: the time of each, and now and then a
    motion, a mode and a moved motor that change the record (a change published)."""
    for n in range(first, first + count):
        now = n * 0.05
        for body in ("1", "2", "3"):
            state.write_controller(
                now, "main", body, updated=now, moving=n % 7 == 0, mode=n % 3,
                last_moved=n % 2 + 1,
            )  # fmt: skip
            state.write_axis(now, "main", body, 1, updated=now)
            if n % 20 == 0:  # a reader folds the reply times in
                state.snapshot()


def test_changing_records_of_the_same_controllers_hold_no_more_memory() -> None:
    state = StateCache()
    state.changes.subscribe(lambda change: None)  # a subscriber that keeps nothing, as the worker's
    tracing = tracemalloc.is_tracing()
    if not tracing:
        tracemalloc.start()
    try:
        _polls(state, 0, 500)
        gc.collect()
        before = tracemalloc.get_traced_memory()[0]
        _polls(state, 500, 5_000)
        gc.collect()
        after = tracemalloc.get_traced_memory()[0]
    finally:
        if not tracing:
            tracemalloc.stop()
    assert state.seq > 15_000  # the records did change, thousands of times
    # 15,000 changes kept in any form would be megabytes
    assert after - before < 20_000, f"{after - before} bytes more after 15,000 changes"
