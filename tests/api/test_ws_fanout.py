"""200 WebSocket clients while an axis moves; one of them stops reading.

Each fast client must receive every position change, in order, with increasing seq. The slow
one stops reading: its socket fills, its queue on the gateway grows to the backlog and it is
closed with 4008, while the others keep receiving every batch as it is published.
"""

from __future__ import annotations

import asyncio
import itertools
import socket

import pytest
from websockets.exceptions import ConnectionClosed

from tests.support.ws_server import MakeWsServer, WsClient

CLIENTS = 200
BATCH = 20
BACKLOG = 50
SNDBUF = 16_384


class Reader:
    """A fast client: reads every message as it comes."""

    def __init__(self, client: WsClient) -> None:
        self.client = client
        self.changes: list[tuple[int, int]] = []  # (seq, position): small, GC-untracked
        self.progress = asyncio.Event()
        self.task = asyncio.create_task(self._run())

    async def _run(self) -> None:
        while True:
            message = await self.client.recv(timeout=60)
            assert message["type"] == "change", message
            self.changes.append((message["seq"], message["data"]["position"]))
            self.progress.set()

    def positions(self) -> list[int]:
        return [position for _, position in self.changes]


async def wait_all(readers: list[Reader], count: int, timeout: float) -> None:
    """Until every reader has ``count`` changes (fails after ``timeout`` real seconds)."""

    async def one(reader: Reader) -> None:
        while len(reader.changes) < count:
            reader.progress.clear()
            if reader.task.done():
                reader.task.result()  # raises what stopped it
            await reader.progress.wait()

    await asyncio.wait_for(asyncio.gather(*(one(r) for r in readers)), timeout)


@pytest.mark.slow
async def test_200_clients_get_every_change_and_a_slow_one_is_dropped(
    make_ws_server: MakeWsServer,
) -> None:
    # A small kernel send buffer, or the slow client's socket would hold megabytes.
    server = await make_ws_server(backlog=BACKLOG, sndbuf=SNDBUF)
    # The slow client: a small receive buffer and a client that holds at most one message,
    # so that its socket fills soon once it stops reading.
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.setblocking(False)
    await asyncio.get_running_loop().sock_connect(sock, ("127.0.0.1", server.port))
    slow = await server.connect(sock=sock, max_queue=1)
    await slow.send({"type": "subscribe", "topics": ["axis:x"]})

    fast = await asyncio.gather(*(server.connect() for _ in range(CLIENTS - 1)))
    snapshots = await asyncio.gather(*(c.subscribe("axis:x") for c in fast))
    assert {s["type"] for s in snapshots} == {"snapshot"}
    readers = [Reader(c) for c in fast]

    pushed, stuck_batches = 0, 0
    while server.feed.dropped == 0:
        assert pushed < 5_000, "the slow client was never dropped"
        for _ in range(BATCH):
            pushed += 1
            server.position("1", 1, pushed)
        # Every other client gets the whole batch, while the slow one does not read; a
        # batch takes some 0.2 s here: 5 s is a bound no waiting on the slow one would meet.
        await wait_all(readers, pushed, timeout=5)
        if max(server.feed.backlogs()) > 0:
            stuck_batches += 1  # the slow one's queue grows: its socket is full
    assert stuck_batches > 0  # the others were served while it was stuck
    assert server.stats.dropped_total == 1
    assert server.feed.clients == CLIENTS - 1

    for _ in range(BATCH):  # after the drop, on as before
        pushed += 1
        server.position("1", 1, pushed)
    await wait_all(readers, pushed, timeout=20)
    for reader in readers:
        assert reader.positions() == list(range(1, pushed + 1))
        seqs = [seq for seq, _ in reader.changes]
        assert all(a < b for a, b in itertools.pairwise(seqs))

    # The slow client reads again: what its socket held, in order, then the close code.
    got: list[int] = []
    with pytest.raises(ConnectionClosed) as closed:
        while True:
            message = await slow.recv()
            if message["type"] == "change":
                got.append(message["data"]["position"])
    assert closed.value.rcvd is not None
    assert (closed.value.rcvd.code, closed.value.rcvd.reason) == (4008, "backlog exceeded")
    assert got == list(range(1, len(got) + 1)) and len(got) < pushed
    for reader in readers:
        reader.task.cancel()
