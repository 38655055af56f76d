"""The edge node's log lines as a test waits for them (woken by each record, no sleeping)."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Iterator
from contextlib import contextmanager


class Lines(logging.Handler):
    """Every record of ``gateway.mqtt`` from now on; ``wait_for`` one containing a text."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []
        self._new = asyncio.Event()

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)
        self._new.set()

    def having(self, text: str) -> list[logging.LogRecord]:
        """The records whose message contains ``text``."""
        return [r for r in self.records if text in r.getMessage()]

    async def wait_for(self, text: str, count: int = 1, timeout: float = 20.0) -> None:
        """Until ``count`` records contain ``text``; fails after ``timeout`` seconds."""
        async with asyncio.timeout(timeout):
            while len(self.having(text)) < count:
                self._new.clear()
                await self._new.wait()


@contextmanager
def mqtt_lines() -> Iterator[Lines]:
    """``Lines`` on the ``gateway.mqtt`` logger for the block."""
    logger = logging.getLogger("gateway.mqtt")
    lines, level = Lines(), logger.level
    logger.addHandler(lines)
    logger.setLevel(logging.DEBUG)
    try:
        yield lines
    finally:
        logger.removeHandler(lines)
        logger.setLevel(level)
