"""Fixtures of the line worker tests: a worker on the in-process simulator, and its client.

``attach(bus)`` serves the bus's scheduler, state cache and a poller of controller 1 (not
started: a test starts it through the channel) from a ``LineWorker`` over two
socketpairs (the channels a worker process has) and returns the ``WorkerClient`` of the API
side, synced (its mirror holds the first snapshot). Both ends run on the test's event loop:
what crosses is what crosses between processes, bytes on a socket.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
from collections.abc import AsyncIterator, Awaitable
from typing import Protocol

import pytest

from gateway.bus.poll_plan import PollConfig
from gateway.bus.poller import attach as attach_poller
from gateway.bus.state import StateCache
from gateway.engine.mirror import StateMirror
from gateway.engine.proxy import SchedulerProxy, WorkerClient
from gateway.engine.wire import Channel
from gateway.engine.worker import LineWorker
from tests.support.bus_rig import Bus, MakeBus

__all__ = ["Attach", "Linked", "MakeBus"]


class Linked:
    """A worker serving a bus, its client, and the channels between them."""

    def __init__(self, bus: Bus, worker: LineWorker, client: WorkerClient) -> None:
        self.bus = bus
        self.worker = worker
        self.client = client
        self.served: asyncio.Task[None] | None = None
        self.sockets: list[socket.socket] = []

    @property
    def proxy(self) -> SchedulerProxy:
        """The API side's proxy of the bus's loop."""
        return self.client.proxies[self.bus.scheduler.name]

    @property
    def mirror(self) -> StateMirror:
        """The API side's copy of the worker's state cache."""
        return self.client.mirror

    @property
    def cache(self) -> StateCache:
        """The worker's own state cache, the one the mirror copies."""
        return self.bus.scheduler.state_cache

    async def connect(self) -> None:
        """Join worker and client by two new socketpairs; wait for the first snapshot."""
        ends: list[tuple[Channel, Channel]] = []
        for _ in range(2):
            a, b = socket.socketpair()
            self.sockets += [a, b]
            ends.append(
                (await asyncio.open_connection(sock=a), await asyncio.open_connection(sock=b))
            )
        (worker_requests, client_requests), (worker_stops, client_stops) = ends
        self.served = asyncio.create_task(self.worker.serve(worker_requests, worker_stops))
        await self.client.attach(client_requests, client_stops)
        await asyncio.wait_for(self.client.synced.wait(), 5.0)

    async def disconnect(self, cause: str) -> None:
        """The client lets go; the worker's ``serve`` returns."""
        await self.client.detach(cause)
        if self.served is not None:
            await asyncio.wait_for(self.served, 5.0)


class Attach(Protocol):
    """``await attach(bus)``, or with the poller's periods (``poll``) of the test's own."""

    def __call__(self, bus: Bus, poll: PollConfig | None = None) -> Awaitable[Linked]: ...


@pytest.fixture
async def attach() -> AsyncIterator[Attach]:
    """``await attach(bus)``: the bus's scheduler served by a worker, with a synced client."""
    made: list[Linked] = []

    async def make(bus: Bus, poll: PollConfig | None = None) -> Linked:
        state = bus.scheduler.state_cache
        poller = attach_poller(bus.scheduler, state, ["1"], poll or PollConfig())
        worker = LineWorker(
            {bus.scheduler.name: bus.scheduler}, state, {bus.scheduler.name: poller}
        )
        client = WorkerClient("w0", [bus.scheduler.name], StateMirror())
        linked = Linked(bus, worker, client)
        made.append(linked)
        await linked.connect()
        return linked

    yield make
    for linked in made:
        with contextlib.suppress(Exception):
            await linked.disconnect("the test is over")
        for sock in linked.sockets:
            sock.close()
