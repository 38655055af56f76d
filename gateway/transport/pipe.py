"""An in-process line: the scheduler talks to a peer object in the same process.

The peer is anything shaped like the simulator's in-process port (``SimPort``): ``write``
bytes to it, read what it sends from its ``reader`` stream, ``close`` it. The gateway never
imports the simulator (import-linter contract), so the shape is a ``typing.Protocol`` here
and the caller hands over a factory, e.g. ``PipeTransport(lambda: SimPort(sim_loop))``. The
factory makes a new peer on every open, so reconnecting works as with a real line.

Nothing here blocks: opening is a call of the factory, and a pump task moves what the peer
sends into the connection's ``ReceiveBuffer`` (where ``discard_input`` can reach it).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from typing import Protocol

from gateway.transport.base import BufferedTransport, ReceiveBuffer, TransportClosed

__all__ = ["Peer", "PeerFactory", "PipeTransport"]

_CHUNK = 4096


class Peer(Protocol):
    """The other end of an in-process line (the shape of ``gateway.sim.serve.SimPort``)."""

    #: What the peer sends; EOF when it goes away.
    reader: asyncio.StreamReader

    def write(self, data: bytes) -> None:
        """Bytes from the gateway to the peer."""

    def close(self) -> None:
        """Disconnect; the peer's ``reader`` then ends (EOF)."""


#: Makes a fresh peer for each open; may raise (e.g. the simulator's line has a host already).
PeerFactory = Callable[[], Peer]


class PipeTransport(BufferedTransport):
    """A ``Transport`` to an in-process peer made by ``connect`` on each open.

    ``url`` only names the line (in logs and errors); ``baud`` is what the peer is told to
    expect, for the scheduler's timing - the bytes themselves move at once.
    """

    def __init__(self, connect: PeerFactory, *, url: str = "pipe://", baud: int = 9600) -> None:
        super().__init__(url, baud)
        self._factory = connect
        self._peer: Peer | None = None
        self._pump: asyncio.Task[None] | None = None

    def write(self, data: bytes) -> None:
        """Hand ``data`` to the peer; ``TransportClosed`` when the line is not open or lost."""
        self._writable()
        assert self._peer is not None
        self._peer.write(bytes(data))

    async def _connect(self, inbox: ReceiveBuffer) -> None:
        try:
            peer = self._factory()
        except Exception as exc:  # whatever the peer's maker refuses with
            raise TransportClosed(f"{self.url}: cannot open: {exc}") from exc
        self._peer = peer
        self._pump = asyncio.create_task(_pump(peer, inbox), name=f"pipe pump {self.url}")

    async def _disconnect(self) -> None:
        pump, self._pump = self._pump, None
        peer, self._peer = self._peer, None
        if pump is not None:
            pump.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await pump
        if peer is not None:
            peer.close()


async def _pump(peer: Peer, inbox: ReceiveBuffer) -> None:
    """Move what the peer sends into ``inbox`` until the peer ends or fails."""
    try:
        while data := await peer.reader.read(_CHUNK):
            inbox.feed(data)
    except Exception as exc:  # the peer's stream failed: the line is lost, say why
        inbox.close(f"line lost: {exc}", cause=exc)
    else:
        inbox.close("the peer closed the line")
