"""The simulated loop served to a host: in process, on a pseudo-terminal, or over TCP.

* ``SimPort``: an in-process port with an asyncio ``StreamReader``, for unit tests and for the
  gateway's transport layer.
* ``PtyLine``: ``os.openpty`` in raw mode; the host opens the slave path like any serial port
  (pyserial ``serial.Serial(path)``). The master end is served without blocking through the
  event loop's reader callbacks. The simulator keeps the slave open itself, so the line
  survives hosts coming and going (without that, the master reads EIO once the last host
  closes).
* ``serve_tcp``: a TCP server, reachable with pyserial's ``socket://HOST:PORT``. One host
  connection at a time, as a serial device server gives one client its port: a second
  connection is closed at once and logged.

Either way the host's bytes go to ``SimLoop`` (which times them at the line's baud rate) and
what the loop delivers is written back. Bytes the host does not read are dropped when the
pseudo-terminal's buffer is full, as a UART overruns.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import tty
from typing import Any

from gateway.sim.loop import HostLink, LineBusy, SimLoop

__all__ = ["PtyLine", "SimPort", "serve_tcp"]

log = logging.getLogger("gateway.sim")
_CHUNK = 4096


class SimPort:
    """An in-process host port: ``write`` bytes, read replies from the ``reader`` stream."""

    def __init__(self, loop: SimLoop) -> None:
        self.reader = asyncio.StreamReader()
        # EOF for readers when the port or the whole loop closes: the line went away.
        self._link = loop.attach(self.reader.feed_data, on_close=self.reader.feed_eof)

    def write(self, data: bytes) -> None:
        """Send bytes to the loop."""
        self._link.write(data)

    async def read(self, n: int = -1) -> bytes:
        """At least one byte (up to ``n``) as soon as some arrive."""
        return await self.reader.read(n)

    def close(self) -> None:
        """Disconnect from the loop; readers see EOF."""
        self._link.close()


class PtyLine:
    """A pseudo-terminal whose slave end is the simulated serial port."""

    def __init__(self, loop: SimLoop) -> None:
        self._loop = loop
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no line editing, no CR/LF translation
        os.set_blocking(self._master, False)
        self.path = os.ttyname(self._slave)
        self._link: HostLink | None = None
        self._aio: asyncio.AbstractEventLoop | None = None

    def start(self) -> str:
        """Start serving (needs a running event loop); the device path hosts open."""
        self._link = self._loop.attach(self._send)
        self._aio = asyncio.get_running_loop()
        self._aio.add_reader(self._master, self._readable)
        return self.path

    def _readable(self) -> None:
        try:
            data = os.read(self._master, _CHUNK)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:  # EIO: no process has the slave open (we keep it open, so rare)
            return
        if data and self._link is not None:
            self._link.write(data)

    def _send(self, data: bytes) -> None:
        try:
            os.write(self._master, data)
        except (BlockingIOError, InterruptedError):
            log.warning("pty %s: host not reading, %d bytes dropped", self.path, len(data))
        except OSError as exc:
            log.warning("pty %s: write failed (%s)", self.path, exc)

    def close(self) -> None:
        """Stop serving and close both ends."""
        if self._aio is not None:
            self._aio.remove_reader(self._master)
            self._aio = None
        if self._link is not None:
            self._link.close()
            self._link = None
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._master = self._slave = -1


class _HostProtocol(asyncio.Protocol):
    """One TCP connection: the host, or a second client to refuse."""

    def __init__(self, loop: SimLoop) -> None:
        self._loop = loop
        self._link: HostLink | None = None
        self._transport: asyncio.Transport | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        peer = transport.get_extra_info("peername")
        try:
            # When the line's host end goes (the loop closes, or drop_host), so does the socket.
            self._link = self._loop.attach(transport.write, on_close=transport.close)
        except LineBusy:
            log.warning("refused a second host connection from %s: the line has a host", peer)
            transport.close()
            return
        self._transport = transport
        log.info("host connected from %s", peer)

    def data_received(self, data: bytes) -> None:
        if self._link is not None:
            self._link.write(data)

    def connection_lost(self, exc: Exception | None) -> None:
        if self._link is not None:
            self._link.close()
            self._link = None
            log.info("host disconnected")


async def serve_tcp(loop: SimLoop, host: str, port: int, **kwargs: Any) -> asyncio.Server:
    """Serve the line on ``host:port`` (port 0: any free port; see ``server.sockets``)."""
    aio = asyncio.get_running_loop()
    return await aio.create_server(lambda: _HostProtocol(loop), host, port, **kwargs)
