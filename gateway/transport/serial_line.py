"""A real serial line: a device path, ``socket://`` or ``rfc2217://``, via pyserial-asyncio-fast.

How each kind is opened, read and closed, and why (pyserial-asyncio-fast 0.16, read in its
source):

* a device path (``/dev/ttyUSB0``): pyserial opens it (``open``, ``tcsetattr``, ``flock``) in a
  worker thread here; ``connection_for_serial`` then reads it through the event loop's reader
  callbacks. In that thread the tty's low-latency flag is set and the adapter's latency timer
  read (``usb_latency``: a USB adapter that holds received bytes slows every exchange). The
  library closes it (drain, ``close``) in the executor. A vanished device
  (USB unplugged, pty closed) reads as an error or as readable-but-empty: the library closes
  the port and ``connection_lost`` carries the reason.
* ``socket://HOST:PORT`` (a serial device server in TCP-server mode: ser2net, Moxa): a TCP
  connection made with ``loop.create_connection`` (Nagle off, as asyncio and uvloop set it) -
  nothing blocks. TCP keepalive is turned on here so that a
  half-open connection (device server rebooted, cable pulled) is found; an orderly close by the
  server arrives as EOF.
* ``rfc2217://HOST:PORT``: pyserial's RFC 2217 port has no file descriptor (the library's
  reader callbacks need one), and its ``open`` negotiates and its ``close`` joins a thread and
  sleeps 0.3 s. So it is opened and closed in a worker thread and pumped by two threads
  (``_ThreadedPort``).

Framing is 8 data bits, no parity, 1 stop bit and no flow control (§2 仕様; §13-1: only TXD and
RXD are used).
"""

from __future__ import annotations

import asyncio
import errno
import logging
import os
import queue
import socket
import threading
import urllib.parse
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any, Protocol, TypeVar

import serial  # type: ignore[import-untyped]
import serial_asyncio_fast

from gateway.transport.base import BufferedTransport, ReceiveBuffer, TransportClosed
from gateway.transport.usb_latency import SYSFS_ROOT, AdapterNotes, AdapterReport, check_adapter

__all__ = ["KeepAlive", "LineKind", "SerialLine"]

log = logging.getLogger("gateway.transport")
_T = TypeVar("_T")
#: How long an rfc2217 pump thread waits for a byte before it looks whether to stop (s).
_POLL = 0.1

#: Options pyserial's ``rfc2217://`` URL understands (serial.rfc2217.Serial.from_url).
RFC2217_OPTIONS = frozenset({"logging", "ign_set_control", "poll_modem", "timeout"})
_ALLOWED = (
    "allowed: a device path such as /dev/ttyUSB0, socket://HOST:PORT (a serial device server "
    "in TCP-server mode) or rfc2217://HOST:PORT"
)


class LineKind(Enum):
    """The three ways to reach a serial line."""

    DEVICE = "device"
    SOCKET = "socket"
    RFC2217 = "rfc2217"

    @classmethod
    def of(cls, url: str) -> LineKind:
        """The kind of ``url``; ``ValueError`` naming the field ``url`` if it is none of them."""
        if any(ord(char) < 0x20 or char == "\x7f" for char in url):
            # a NUL makes the OS refuse the path with a ValueError, a newline hides in the log
            raise ValueError(f"url {url!r}: control characters are not allowed; {_ALLOWED}")
        if "://" not in url:
            if url.startswith("/") and url.strip() == url and len(url) > 1:
                return cls.DEVICE
            raise ValueError(f"url {url!r}: a device path must be absolute; {_ALLOWED}")
        parts = urllib.parse.urlsplit(url)
        scheme = parts.scheme.lower()
        if scheme not in ("socket", "rfc2217"):
            raise ValueError(f"url {url!r}: unknown scheme {scheme + '://'!r}; {_ALLOWED}")
        try:
            port = parts.port
        except ValueError:
            port = None
        if (
            not parts.hostname
            or port is None
            or not 0 < port < 65536
            or parts.path not in ("", "/")
        ):
            raise ValueError(f"url {url!r}: expected {scheme}://HOST:PORT (port 1-65535)")
        options = set(urllib.parse.parse_qs(parts.query, keep_blank_values=True))
        allowed = RFC2217_OPTIONS if scheme == "rfc2217" else frozenset()
        if options - allowed:
            raise ValueError(
                f"url {url!r}: unknown option(s) {sorted(options - allowed)}; "
                f"{scheme}:// takes {sorted(allowed) or 'none'}"
            )
        return cls.SOCKET if scheme == "socket" else cls.RFC2217


@dataclass(frozen=True)
class KeepAlive:
    """TCP keepalive for network lines: the first probe after ``idle`` s without traffic, then
    one every ``interval`` s; ``count`` unanswered probes drop the connection.

    The default finds a half-open connection within 10 + 3 * 5 = 25 s of silence. The same bound
    applies to data that is never acknowledged (``TCP_USER_TIMEOUT``, Linux), as keepalive does
    not probe while data waits for its acknowledgement.
    """

    idle: float = 10.0
    interval: float = 5.0
    count: int = 3

    def apply(self, sock: Any) -> None:
        """Turn keepalive on for ``sock`` (a socket, or asyncio's wrapper of one)."""
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
        options = [
            ("TCP_KEEPIDLE", max(1, round(self.idle))),
            ("TCP_KEEPINTVL", max(1, round(self.interval))),
            ("TCP_KEEPCNT", max(1, self.count)),
            ("TCP_USER_TIMEOUT", round((self.idle + self.interval * self.count) * 1000)),
        ]
        for name, value in options:
            option = getattr(socket, name, None)  # not every platform has all of them
            if option is not None:
                sock.setsockopt(socket.IPPROTO_TCP, option, value)


class _Port(Protocol):
    """The open line under a ``SerialLine``: where bytes go, and how it is closed."""

    def write(self, data: bytes) -> None: ...

    async def aclose(self) -> None: ...


class LineProtocol(asyncio.Protocol):
    """The library's callbacks into one connection's ``ReceiveBuffer``."""

    def __init__(self, inbox: ReceiveBuffer) -> None:
        self.inbox = inbox
        self.done: asyncio.Future[None] = asyncio.get_running_loop().create_future()

    def data_received(self, data: bytes) -> None:
        """Bytes arrived."""
        self.inbox.feed(data)

    def eof_received(self) -> bool:
        """The peer closed its end (a device server closing the TCP connection)."""
        self.inbox.close("connection closed by the other end")
        return False  # close our end too: the line is of no use half-closed

    def connection_lost(self, exc: Exception | None) -> None:
        """The line is gone: closed by us, by the other end, or broken (``exc``)."""
        reason = f"line lost: {exc}" if exc is not None else "connection closed by the other end"
        self.inbox.close(reason, cause=exc)
        if not self.done.done():
            self.done.set_result(None)


class _AioPort:
    """A line the library drives through the event loop (device path, ``socket://``)."""

    def __init__(self, transport: asyncio.Transport, protocol: LineProtocol, timeout: float):
        self._transport = transport
        self._protocol = protocol
        self._timeout = timeout

    def write(self, data: bytes) -> None:
        self._transport.write(data)

    async def aclose(self) -> None:
        self._transport.close()  # the library drains and closes the port in its executor
        try:
            await asyncio.wait_for(asyncio.shield(self._protocol.done), self._timeout)
        except TimeoutError:
            log.warning("line did not close within %.1f s: dropping what was unsent", self._timeout)
            self._transport.abort()


class _ThreadedPort:
    """An open pyserial port without a file descriptor (``rfc2217://``), pumped by threads.

    One thread reads (waiting ``_POLL`` s at a time, so that it sees a close), one writes in
    order; what they get or meet reaches the ``LineProtocol`` on the event loop's thread.
    """

    def __init__(self, port: Any, protocol: LineProtocol, loop: asyncio.AbstractEventLoop) -> None:
        self._port = port
        self._protocol = protocol
        self._loop = loop
        self._outbox: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
        self._closing = threading.Event()
        name = f"rc233 {port.portstr}"
        self._threads = [
            threading.Thread(target=self._read_loop, name=f"{name} reader", daemon=True),
            threading.Thread(target=self._write_loop, name=f"{name} writer", daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    def write(self, data: bytes) -> None:
        self._outbox.put(bytes(data))

    async def aclose(self) -> None:
        self._closing.set()
        self._outbox.put(None)
        await asyncio.to_thread(self._shut)
        self._protocol.connection_lost(None)

    def _shut(self) -> None:
        self._port.close()  # joins pyserial's own telnet thread, then sleeps 0.3 s
        for thread in self._threads:
            thread.join()

    def _report(self, callback: Callable[..., None], *args: Any) -> None:
        if self._closing.is_set():
            return
        try:
            self._loop.call_soon_threadsafe(callback, *args)
        except RuntimeError:  # the event loop is closed: nobody is listening any more
            self._closing.set()

    def _read_loop(self) -> None:
        port = self._port
        try:
            while not self._closing.is_set():
                data = port.read(1)  # b"" after _POLL s, or once when the connection ended
                if data and port.in_waiting:
                    data += port.read(port.in_waiting)
                if data:
                    self._report(self._protocol.data_received, data)
        except Exception as exc:  # SerialException: "connection failed (reader thread died)"
            self._report(self._protocol.connection_lost, exc)

    def _write_loop(self) -> None:
        while (data := self._outbox.get()) is not None:
            try:
                self._port.write(data)
            except Exception as exc:  # SerialException: the socket failed
                self._report(self._protocol.connection_lost, exc)
                return


class SerialLine(BufferedTransport):
    """A serial line through pyserial-asyncio-fast: device path, socket:// or rfc2217://.

    ``open_timeout`` bounds an open (a TCP connect to an unreachable server, an RFC 2217
    negotiation); ``close_timeout`` bounds waiting for the port to drain when closing.
    ``sysfs_root`` is where a device path's adapter settings are read (``usb_latency``).
    ``ValueError`` at once if ``url`` is none of the three kinds.
    """

    def __init__(
        self,
        url: str,
        baud: int,
        *,
        open_timeout: float = 10.0,
        close_timeout: float = 3.0,
        keepalive: KeepAlive | None = KeepAlive(),
        sysfs_root: Path = SYSFS_ROOT,
    ) -> None:
        super().__init__(url, baud)
        self.kind = LineKind.of(url)
        self.open_timeout = open_timeout
        self.close_timeout = close_timeout
        self.keepalive = keepalive
        self.sysfs_root = sysfs_root
        self._port: _Port | None = None
        self._adapter: AdapterReport | None = None
        self._notes = AdapterNotes(url, log)

    @property
    def adapter(self) -> AdapterReport | None:
        """What the last open of a device path learned about its adapter (``None`` for
        ``socket://`` and ``rfc2217://``, and before the first open)."""
        return self._adapter

    def write(self, data: bytes) -> None:
        """Queue ``data`` for the line; ``TransportClosed`` when it is not open or was lost."""
        self._writable()
        assert self._port is not None
        self._port.write(data)

    async def _connect(self, inbox: ReceiveBuffer) -> None:
        protocol = LineProtocol(inbox)
        try:
            if self.kind is LineKind.SOCKET:
                self._port = await self._open_socket(protocol)
            elif self.kind is LineKind.DEVICE:
                self._port = await self._open_device(protocol)
            else:
                self._port = await self._open_rfc2217(protocol)
        except TimeoutError as exc:
            raise TransportClosed(
                f"{self.url}: cannot open: no connection within {self.open_timeout:g} s"
            ) from exc
        except OSError as exc:  # serial.SerialException is an OSError too
            raise TransportClosed(f"{self.url}: cannot open: {_why(exc)}") from exc

    async def _disconnect(self) -> None:
        port, self._port = self._port, None
        if port is not None:
            await port.aclose()

    def _settings(self) -> dict[str, Any]:
        """pyserial's settings: the configured baud, 8N1, no flow control (§2, §13-1)."""
        return {
            "baudrate": self.baud,
            "bytesize": serial.EIGHTBITS,
            "parity": serial.PARITY_NONE,
            "stopbits": serial.STOPBITS_ONE,
            "xonxoff": False,
            "rtscts": False,
            "dsrdtr": False,
        }

    async def _open_socket(self, protocol: LineProtocol) -> _Port:
        # A plain TCP connection on the event loop. Not the library's create_serial_connection:
        # it sets attributes on the loop's transport object, which uvloop's (the loop serve
        # runs on) does not take, and nothing of the pyserial object it makes is used here.
        parts = urllib.parse.urlsplit(self.url)
        host, port = parts.hostname or "", parts.port or 0  # both there: LineKind.of
        event_loop = asyncio.get_running_loop()
        transport, _ = await asyncio.wait_for(
            event_loop.create_connection(lambda: protocol, host, port),
            self.open_timeout,
        )
        sock = transport.get_extra_info("socket")
        if self.keepalive is not None and sock is not None:
            self.keepalive.apply(sock)
        return _AioPort(transport, protocol, self.close_timeout)

    async def _open_device(self, protocol: LineProtocol) -> _Port:
        # exclusive: a second program on the same port would garble the loop (flock, POSIX)
        # the port alone comes back (a late one is closed by _in_thread); the report beside it
        found: list[AdapterReport] = []

        def open_and_check() -> Any:
            port = serial.serial_for_url(self.url, exclusive=True, **self._settings())
            found.append(check_adapter(port, self.url, self.sysfs_root))
            return port

        port = await self._in_thread(open_and_check)
        self._adapter = found[0]
        self._notes.tell(self._adapter)
        event_loop = asyncio.get_running_loop()
        transport, _ = await serial_asyncio_fast.connection_for_serial(
            event_loop, lambda: protocol, port
        )
        return _AioPort(transport, protocol, self.close_timeout)

    async def _open_rfc2217(self, protocol: LineProtocol) -> _Port:
        port = await self._in_thread(
            lambda: serial.serial_for_url(self.url, timeout=_POLL, **self._settings())
        )
        sock = getattr(port, "_socket", None)  # pyserial keeps the connection there
        if self.keepalive is not None and sock is not None:
            self.keepalive.apply(sock)
        return _ThreadedPort(port, protocol, asyncio.get_running_loop())

    async def _in_thread(self, make: Callable[[], _T]) -> _T:
        """``make()`` in a worker thread, within ``open_timeout``; a port it opens after the
        time-out (or after a cancel) is closed in the executor instead of leaking."""
        task = asyncio.ensure_future(asyncio.to_thread(make))
        try:
            return await asyncio.wait_for(asyncio.shield(task), self.open_timeout)
        except BaseException:
            task.add_done_callback(_close_late)
            raise


#: What an unplugged device (a USB adapter not there, its by-id link gone) fails an open with.
_ABSENT = frozenset({errno.ENOENT, errno.ENODEV, errno.ENXIO})


def _why(exc: OSError) -> str:
    """Why an open failed, said plainly when the device is absent (pyserial's message names
    the path and the error twice); its own words otherwise (a lock held, a refused rate)."""
    if exc.errno in _ABSENT:
        return f"the device is not present ({os.strerror(exc.errno)})"
    return str(exc)


def _close_late(task: asyncio.Future[Any]) -> None:
    if task.cancelled() or task.exception() is not None:
        return
    asyncio.get_running_loop().run_in_executor(None, task.result().close)
