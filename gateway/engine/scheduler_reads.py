"""The parts of a scheduler the API process reads besides requests and link state, kept on
its side of the channel: the line's rate and adapter report, the trace, the poller's switch.

``RemoteLine`` is what the worker last said of its line (``LINE`` before every link event,
and in each snapshot): service/ reads ``timing.baud`` and ``transport.adapter`` of a
scheduler, and a proxy answers both from here. ``RemoteTrace`` is a ``LineTrace`` whose
switches are also sent to the worker and whose records are those the worker sends while it
traces; a worker started again is told the switches anew. ``PollerProxy`` is the poller
service/ starts and stops (around a change of rate), carried as ``polling(on)`` requests.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from gateway.bus.trace import LineTrace, TraceRecord

if TYPE_CHECKING:  # a type only: the API side opens no line
    from gateway.transport.usb_latency import AdapterReport

__all__ = ["PollerProxy", "RemoteLine", "RemoteTrace"]

log = logging.getLogger("gateway.engine")


@dataclass
class RemoteLine:
    """A worker's line as last opened: its rate (bps) and what was learnt of a local adapter
    (None: a network line, or not opened yet)."""

    baud: int
    adapter: AdapterReport | None = None


#: what a trace's switches are sent as: (whole loop, bodies, hex mode, clear the records)
TraceSwitches = Callable[[bool, tuple[str, ...], bool, bool], None]


class RemoteTrace(LineTrace):
    """A loop's trace in the API process: records as the worker traced them."""

    def __init__(self, send: TraceSwitches, size: int = 5000) -> None:
        super().__init__(size)
        self._send = send

    def enable(self, on: bool = True, *, hex_mode: bool | None = None) -> None:
        """Trace every controller of the loop (or stop), here and in the worker."""
        super().enable(on, hex_mode=hex_mode)
        self.resend()

    def enable_body(self, body: str, on: bool = True) -> None:
        """Trace one controller (in addition to ``all``), here and in the worker."""
        super().enable_body(body, on)
        self.resend()

    def clear(self) -> None:
        """Forget the records, here and in the worker."""
        super().clear()
        self._send(self.all, tuple(sorted(self.bodies)), self.hex_mode, True)

    def resend(self) -> None:
        """Tell the worker the switches as they are here (a new worker starts untraced)."""
        self._send(self.all, tuple(sorted(self.bodies)), self.hex_mode, False)

    def take(self, record: TraceRecord) -> None:
        """One record the worker traced."""
        self._records.append(record)


class PollerProxy:
    """A loop's poller as service/ switches it: ``start()`` at once (the request goes in a
    task: a poller's start answers nothing), ``await stop()`` until no poll is in flight."""

    def __init__(self, name: str, polling: Callable[[bool], Awaitable[None]]) -> None:
        self.name = name
        self._polling = polling
        self._starting: set[asyncio.Task[None]] = set()

    def start(self) -> None:
        """Start polling in the worker (a worker down now starts polling anyway when back)."""
        task = asyncio.ensure_future(self._start())
        self._starting.add(task)
        task.add_done_callback(self._starting.discard)

    async def _start(self) -> None:
        try:
            await self._polling(True)
        except Exception as exc:  # the worker went away: a new one polls from its start
            log.info("loop %s: polling not restarted in the worker: %s", self.name, exc)

    async def stop(self) -> None:
        """Stop polling in the worker; returns when no poll is in flight."""
        await self._polling(False)
