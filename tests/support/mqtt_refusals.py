"""The edge node's log records, and the moment a broker first refused it."""

from __future__ import annotations

import asyncio
import logging


class Refusals(logging.Handler):
    """Every record of ``gateway.mqtt``; ``refused`` set at the first reconnect warning."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.texts: list[str] = []
        self.refused = asyncio.Event()

    def emit(self, record: logging.LogRecord) -> None:
        self.texts.append(self.format(record))
        if record.levelno == logging.WARNING and "again in" in record.getMessage():
            self.refused.set()
