"""The byte pipe of one serial line, as the loop scheduler sees it.

A ``Transport`` carries the bytes of one RS-232C loop: a device path, a serial device server
(``socket://``, ``rfc2217://``) or an in-process peer such as the simulator. The scheduler is
its only user (DESIGN.md invariant 1); everything protocol-specific sits above it. Opening and
closing may block in the serial library, so implementations do them off the event loop.

``BufferedTransport`` is what the implementations share: per connection, a ``ReceiveBuffer``
holds the bytes received and not read yet and, once the line is gone, the reason why, so that
``read`` and ``write`` raise ``TransportClosed`` with that reason at once. A reader that would
only wait for every chunk anyway can have them handed to it as they arrive instead
(``deliver``: called from the connection's ``data_received``, no task woken per chunk).
"""

from __future__ import annotations

import asyncio
from abc import ABC, abstractmethod
from collections.abc import Callable

from gateway.errors import GatewayError
from gateway.transport.usb_latency import AdapterReport

__all__ = ["BufferedTransport", "ReceiveBuffer", "Sink", "Transport", "TransportClosed"]


class TransportClosed(GatewayError):
    """The line went away: port unplugged, TCP connection dropped, peer closed."""


class Transport(ABC):
    """One serial line: open it, write bytes, read what comes back, close it."""

    #: Where the line is, as configured (``/dev/ttyUSB0``, ``socket://host:port``, ...)
    url: str
    #: The line's rate in bits per second (8N1: 10 bits a character)
    baud: int

    @abstractmethod
    async def open(self) -> None:
        """Open the line (off the event loop); ``TransportClosed`` or ``OSError`` if it fails."""

    @property
    def adapter(self) -> AdapterReport | None:
        """What the last open learned about a local adapter (low-latency flag, latency
        timer); ``None`` for lines that have none (network, in-process) or before an open."""
        return None

    @abstractmethod
    async def close(self) -> None:
        """Close the line (off the event loop); closing a closed line does nothing."""

    @property
    @abstractmethod
    def is_open(self) -> bool:
        """True between a successful ``open`` and ``close`` or the loss of the line."""

    @abstractmethod
    def write(self, data: bytes) -> None:
        """Queue ``data`` for the line; ``TransportClosed`` when it is not open."""

    @abstractmethod
    async def read(self) -> bytes:
        """The next bytes received (at least one); ``TransportClosed`` when the line is gone."""

    @abstractmethod
    def discard_input(self) -> bytes:
        """Drop what was received and not read yet; return it (for the trace)."""

    def deliver(self, sink: Sink | None) -> bool:
        """Hand each chunk of the open connection to ``sink`` as it arrives instead of keeping
        it for ``read`` (None: keep them again); False if this transport cannot."""
        return False


class Sink(ABC):
    """Who takes a connection's chunks as they arrive (``Transport.deliver``)."""

    @abstractmethod
    def received(self, data: bytes) -> None:
        """Bytes from the line (at least one), in the order they came."""

    @abstractmethod
    def closed(self, error: TransportClosed) -> None:
        """The connection is gone (once), and why; nothing is received after it."""


class ReceiveBuffer:
    """What one connection received and nobody read yet; closed once, with a reason.

    Bytes that arrived before the line was lost are still handed out by ``read`` (they did
    arrive); after that ``read`` raises. Closing on purpose (``drop=True``) drops them.
    """

    def __init__(self, url: str) -> None:
        self.url = url
        self._data = bytearray()
        self._reason: str | None = None
        self._cause: BaseException | None = None
        self._changed = asyncio.Event()
        self._sink: Sink | None = None

    @property
    def is_open(self) -> bool:
        """False once the connection is closed or lost."""
        return self._reason is None

    @property
    def pending(self) -> int:
        """How many bytes wait to be read."""
        return len(self._data)

    def error(self) -> TransportClosed:
        """The exception that says why the line is closed (a new one each time)."""
        error = TransportClosed(f"{self.url}: {self._reason or 'open'}")
        error.__cause__ = self._cause
        return error

    def deliver(self, sink: Sink | None) -> None:
        """Hand chunks to ``sink`` from now on (what waits first); None: keep them again."""
        self._sink = sink
        if sink is None:
            return
        if self._data:
            sink.received(self.discard())
        if self._reason is not None:
            self._sink = None
            sink.closed(self.error())

    def feed(self, data: bytes) -> None:
        """Bytes from the line; ignored once the connection is closed."""
        if self._reason is None and data:
            sink = self._sink
            if sink is not None:
                sink.received(data)
                return
            self._data += data
            self._changed.set()

    def close(self, reason: str, *, cause: BaseException | None = None, drop: bool = False) -> None:
        """End the connection; the first reason given is the one readers see."""
        if self._reason is None:
            self._reason = reason
            self._cause = cause
        if drop:
            self._data.clear()
        self._changed.set()
        sink, self._sink = self._sink, None
        if sink is not None:
            sink.closed(self.error())

    def discard(self) -> bytes:
        """Take everything waiting, without waiting."""
        data = bytes(self._data)
        self._data.clear()
        return data

    async def read(self) -> bytes:
        """Everything waiting (at least one byte, waiting for it); raise once closed and empty."""
        await self._until(lambda: bool(self._data))
        return self.discard()

    async def wait_pending(self, size: int) -> None:
        """Wait until at least ``size`` bytes wait to be read (reading none of them)."""
        await self._until(lambda: len(self._data) >= size)

    async def _until(self, ready: Callable[[], bool]) -> None:
        while not ready():
            if self._reason is not None:
                raise self.error()
            self._changed.clear()
            await self._changed.wait()


class BufferedTransport(Transport):
    """A ``Transport`` whose connections each fill a ``ReceiveBuffer``.

    Subclasses connect (``_connect``, feeding the buffer they are given and closing it when the
    line is lost), disconnect (``_disconnect``, idempotent) and send (``write``, after
    ``_writable``). Opening and closing are serialised, so a close during an open waits for it.
    """

    def __init__(self, url: str, baud: int) -> None:
        self.url = url
        self.baud = baud
        self._inbox: ReceiveBuffer | None = None
        self._lock = asyncio.Lock()

    @abstractmethod
    async def _connect(self, inbox: ReceiveBuffer) -> None:
        """Open the line and feed ``inbox``; ``TransportClosed`` if it cannot be opened."""

    @abstractmethod
    async def _disconnect(self) -> None:
        """Release the line (also after it was lost); doing it twice does nothing."""

    async def open(self) -> None:
        """Open the line; nothing happens if it is open. ``TransportClosed`` if it fails."""
        async with self._lock:
            if self.is_open:
                return
            if self._inbox is not None:  # lost: release what is left of the old connection
                self._inbox = None
                await self._disconnect()
            inbox = ReceiveBuffer(self.url)
            await self._connect(inbox)
            self._inbox = inbox

    async def close(self) -> None:
        """Close the line; a waiting ``read`` raises ``TransportClosed``. Unread bytes go."""
        async with self._lock:
            inbox, self._inbox = self._inbox, None
            if inbox is None:
                return
            inbox.close("closed by the gateway", drop=True)
            await self._disconnect()

    @property
    def is_open(self) -> bool:
        """True between a successful ``open`` and ``close`` or the loss of the line."""
        return self._inbox is not None and self._inbox.is_open

    @property
    def pending(self) -> int:
        """How many received bytes wait to be read (0 when closed)."""
        return self._inbox.pending if self._inbox is not None else 0

    async def read(self) -> bytes:
        """The next bytes received (at least one); ``TransportClosed`` when the line is gone."""
        return await self._current().read()

    async def wait_pending(self, size: int) -> None:
        """Wait until ``size`` received bytes wait to be read; ``TransportClosed`` if lost."""
        await self._current().wait_pending(size)

    def discard_input(self) -> bytes:
        """Drop what was received and not read yet; return it (for the trace)."""
        return self._inbox.discard() if self._inbox is not None else b""

    def deliver(self, sink: Sink | None) -> bool:
        """Hand each chunk of the open connection to ``sink`` as it arrives (see ``Transport``);
        ``TransportClosed`` if there is no connection."""
        self._current().deliver(sink)
        return True

    def _current(self) -> ReceiveBuffer:
        if self._inbox is None:
            raise TransportClosed(f"{self.url}: not open")
        return self._inbox

    def _writable(self) -> ReceiveBuffer:
        """The open connection's buffer; ``TransportClosed`` (with the reason) if there is none."""
        inbox = self._current()
        if not inbox.is_open:
            raise inbox.error()
        return inbox
