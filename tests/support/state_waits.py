"""Waiting on the state cache in tests: re-check a condition on every change, never sleep."""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from gateway.bus.state import StateCache


async def until_state(state: StateCache, check: Callable[[], bool], timeout: float) -> None:
    """Return once ``check()`` holds, re-checked after every change of ``state``; TimeoutError
    after ``timeout`` real seconds."""
    changed = asyncio.Event()
    stop = state.changes.subscribe(lambda _change: changed.set())
    try:
        async with asyncio.timeout(timeout):
            while not check():
                changed.clear()
                await changed.wait()
    finally:
        stop()
