"""A line worker process: ``python -m gateway.engine.process REQUESTS_FD STOPS_FD``.

Started by a ``WorkerSupervisor`` with the two channel sockets inherited at those file
descriptors. The first message on the request channel is ``(START, [LoopSpec, ...])``; the
worker opens each loop's line, starts its scheduler and poller, serves the client until it
closes the request channel (the API process stopped, or went away), then lets each loop's
transaction in flight finish and closes the lines.

``run_worker`` takes the loops' lines from ``open_lines``: here each loop's ``url`` at its
``baud``. Another program builds them otherwise and runs the same engine (``serve
--simulate``'s worker, gateway/cli/simulated_worker.py, puts a simulator behind each loop),
so that users have one engine code path whatever is at the end of the line.
"""

from __future__ import annotations

import asyncio
import logging
import signal
import socket
import sys
from collections.abc import AsyncIterator, Callable, Mapping, Sequence
from contextlib import AbstractAsyncContextManager, asynccontextmanager

from gateway.bus.poller import Poller, attach
from gateway.bus.scheduler import LoopScheduler
from gateway.bus.state import StateCache
from gateway.engine.wire import Channel, Kind, read_message
from gateway.engine.worker import LineWorker
from gateway.engine.worker_spec import LoopSpec
from gateway.heap_trace import install_from_env
from gateway.transport.base import Transport
from gateway.transport.factory import open_transport

__all__ = ["OpenLines", "main", "open_urls", "run_worker"]

log = logging.getLogger("gateway.engine")

#: Real seconds a worker lets a transaction in flight finish when its client has gone.
DRAIN_SECONDS = 5.0

#: Each loop's line (by loop name) for the worker's loops, for as long as the context lasts.
OpenLines = Callable[[Sequence[LoopSpec]], AbstractAsyncContextManager[Mapping[str, Transport]]]


@asynccontextmanager
async def open_urls(specs: Sequence[LoopSpec]) -> AsyncIterator[Mapping[str, Transport]]:
    """Each loop's ``url`` at its ``baud`` (not opened yet: its scheduler opens it)."""
    yield {spec.name: open_transport(spec.url, spec.baud) for spec in specs}


async def _channel(fd: int) -> Channel:
    return await asyncio.open_connection(sock=socket.socket(fileno=fd))


async def run_worker(requests_fd: int, stops_fd: int, open_lines: OpenLines = open_urls) -> None:
    """Serve the loops the first message names, on the lines ``open_lines`` gives, until
    the client goes away."""
    requests, stops = await _channel(requests_fd), await _channel(stops_fd)
    start = await read_message(requests[0])
    if start is None:
        return  # the client went away before saying what to run
    if start[0] != Kind.START:
        raise SystemExit(f"line worker: the first message is {start[0]!r}, not {Kind.START!r}")
    specs: list[LoopSpec] = start[1]
    async with open_lines(specs) as lines:
        await _serve(specs, lines, requests, stops)


async def _serve(
    specs: Sequence[LoopSpec], lines: Mapping[str, Transport], requests: Channel, stops: Channel
) -> None:
    state = StateCache()
    schedulers: dict[str, LoopScheduler] = {}
    pollers: dict[str, Poller] = {}
    for spec in specs:
        scheduler = LoopScheduler(lines[spec.name], spec.config)
        schedulers[spec.name] = scheduler
        pollers[spec.name] = attach(scheduler, state, spec.bodies, spec.poll)
    await asyncio.gather(*(s.start() for s in schedulers.values()))
    for poller in pollers.values():
        poller.start()
    try:
        await LineWorker(schedulers, state, pollers).serve(requests, stops)
    finally:
        await asyncio.gather(*(p.stop() for p in pollers.values()))
        await asyncio.gather(*(s.close(drain=DRAIN_SECONDS) for s in schedulers.values()))


def main(open_lines: OpenLines = open_urls) -> None:
    """A worker program's entry point (see the module): the channels' descriptors are its
    two arguments.

    SIGINT and SIGTERM are ignored: a Ctrl+C in the terminal (the whole foreground group)
    and systemd's stop (the whole control group) are meant for the API process, which then
    closes the channels; the worker lets the transaction in flight finish and exits. Dying
    at once would cut that transaction and report a worker death while the API drains."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    logging.basicConfig(
        level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s [worker]: %(message)s"
    )
    # RC233_TRACEMALLOC, inherited from serve: the worker's heap is traced on its own
    install_from_env(role="line worker")
    asyncio.run(run_worker(int(sys.argv[1]), int(sys.argv[2]), open_lines))


if __name__ == "__main__":
    main()
