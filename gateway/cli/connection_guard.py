"""Limits on the HTTP connections themselves, before any request reaches the app.

uvicorn's httptools protocol keeps every connection as long as the client likes, buffers a
request head of any size and accepts until the process runs out of descriptors, after which
every new connection, an operator's stop included, is closed unanswered. ``GuardedHttp``
(uvicorn's ``http`` protocol class) adds, per connection:

- a size limit on the request head (request line and headers): ``431`` and closed;
- an idle limit: a connection that sends nothing that long is closed;
- a deadline for a complete request head once its first byte came: ``408`` and closed
  (a client trickling a byte a second);

and, over all connections (``ConnectionBook``):

- at most ``max_per_client`` connections from one client address (``429`` and closed);
- at most ``max_connections`` in all, fewer when the descriptor limit would not leave a
  reserve for the loops' ports, files and the broker: a connection beyond that pushes out the
  one that has waited longest without a request in progress, so a new request (a stop, a
  health check) is always heard while hostile connections merely rotate.

A WebSocket keeps its place after the upgrade until it closes.
"""

from __future__ import annotations

import asyncio
import logging
import resource
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any

from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol

from gateway.service.config import ConnectionSettings

__all__ = [
    "ConnectionBook",
    "GuardedHttp",
    "connection_limit",
    "guarded_http",
    "uvicorn_connection_options",
]

log = logging.getLogger("gateway.connections")

#: Descriptors kept free of HTTP connections: serial ports, the audit log, the broker,
#: the files a request opens, and the connections accepted in one burst before the oldest
#: waiting ones are closed.
RESERVED_DESCRIPTORS = 128

#: Seconds between two log lines about refused or pushed-out connections.
REPORT_INTERVAL = 60.0

#: Seconds a refused connection is still read (and the bytes dropped) after the answer.
LINGER = 1.0


def connection_limit(wanted: int) -> int:
    """How many connections fit: ``wanted``, after raising the soft descriptor limit up to
    the hard one as far as needed (systemd's default soft limit is 1,024), less the reserve."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    needed = wanted + RESERVED_DESCRIPTORS
    if soft != resource.RLIM_INFINITY and soft < needed:
        raised = needed if hard == resource.RLIM_INFINITY else min(needed, hard)
        try:
            if raised > soft:
                resource.setrlimit(resource.RLIMIT_NOFILE, (raised, hard))
                soft = raised
        except (OSError, ValueError):  # the unit's system-call filter forbids it (@resources)
            pass
    if soft == resource.RLIM_INFINITY:
        return wanted
    limit = max(1, min(wanted, soft - RESERVED_DESCRIPTORS))
    if limit < wanted:
        log.warning(
            "connections.max_connections %d lowered to %d: the descriptor limit is %d "
            "(raise LimitNOFILE)", wanted, limit, soft,
        )  # fmt: skip
    return limit


@dataclass
class ConnectionBook:
    """Every open HTTP connection of the server with its client address: counts per
    address, and the connections without a request in progress, longest waiting first (the
    ones pushed out at the limit)."""

    max_connections: int
    max_per_client: int
    open: dict[Any, str] = field(default_factory=dict)
    per_client: dict[str, int] = field(default_factory=dict)
    waiting: OrderedDict[Any, None] = field(default_factory=OrderedDict)
    refused: int = 0
    pushed_out: int = 0
    _logged: tuple[float, int, int] = (-REPORT_INTERVAL, 0, 0)  # when, refused, pushed out

    def admit(self, connection: Any, client: str) -> bool:
        """Count ``connection`` from ``client``; False: refuse it (its address has its
        share). At the total limit the longest-waiting idle connection is closed for it."""
        if self.per_client.get(client, 0) >= self.max_per_client:
            self.refused += 1
            self._report()
            return False
        while len(self.open) >= self.max_connections and self.waiting:
            oldest, _ = self.waiting.popitem(last=False)
            self.release(oldest)
            self.pushed_out += 1
            oldest.push_out()
            self._report()
        if len(self.open) >= self.max_connections:
            self.refused += 1
            self._report()
            return False
        self.open[connection] = client
        self.per_client[client] = self.per_client.get(client, 0) + 1
        return True

    def release(self, connection: Any) -> None:
        """``connection`` closed (or is closing): its place is free."""
        client = self.open.pop(connection, None)
        if client is None:
            return
        self.waiting.pop(connection, None)
        left = self.per_client.get(client, 1) - 1
        if left > 0:
            self.per_client[client] = left
        else:
            self.per_client.pop(client, None)

    def _report(self) -> None:
        """One WARNING per ``REPORT_INTERVAL`` with the counts since the last one: a flood
        of connections must not become a flood of log lines."""
        now = time.monotonic()
        when, refused, pushed = self._logged
        if now - when < REPORT_INTERVAL:
            return
        self._logged = (now, self.refused, self.pushed_out)
        log.warning(
            "connections: %d refused (an address over its share, or no place), %d closed "
            "for newer ones since the last report; %d open from %d addresses",
            self.refused - refused, self.pushed_out - pushed, len(self.open),
            len(self.per_client),
        )  # fmt: skip

    def mark_waiting(self, connection: Any) -> None:
        """``connection`` has no request in progress: it may be pushed out."""
        if connection in self.open:
            self.waiting[connection] = None
            self.waiting.move_to_end(connection)

    def mark_busy(self, connection: Any) -> None:
        """A request of ``connection`` is in progress: it stays."""
        self.waiting.pop(connection, None)


class _HeadTooLarge(Exception):
    """Raised from a parser callback: the head passed the limit (uvicorn then answers)."""


def _plain(status: bytes, text: str) -> bytes:
    body = text.encode("ascii")
    return (
        b"HTTP/1.1 " + status + b"\r\ncontent-type: text/plain; charset=utf-8\r\n"
        b"content-length: " + str(len(body)).encode("ascii") + b"\r\n"
        b"connection: close\r\n\r\n" + body
    )


class GuardedHttp(HttpToolsProtocol):
    """uvicorn's httptools protocol with the limits of ``settings`` (see the module)."""

    settings: ConnectionSettings
    book: ConnectionBook

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._address = ""
        self._in_head = True
        self._head_bytes = 0
        self._head_size = 0
        self._head_too_large = False
        self._timer: asyncio.TimerHandle | None = None
        self._upgraded = False
        self._refused = False

    # The connection
    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        """Count the connection (or refuse it) and give it ``idle_timeout`` to begin."""
        super().connection_made(transport)
        self._address = self.client[0] if self.client else ""
        if not self.book.admit(self, self._address):
            self._refuse(b"429 Too Many Requests", "too many connections from this address\n")
            return
        self.book.mark_waiting(self)
        self._arm(self.settings.idle_timeout, self._idle)

    def connection_lost(self, exc: Exception | None) -> None:
        """Free the connection's place."""
        self._disarm()
        self.book.release(self)
        super().connection_lost(exc)

    def data_received(self, data: bytes) -> None:
        """Parse; a head still open past ``max_head_bytes`` is answered ``431``."""
        if self._refused:
            return  # what the client still sends after the answer: dropped unread
        super().data_received(data)
        if self._refused or not self._in_head or self.transport.is_closing():
            return
        # Everything since the head began is head: a bound on the parser's buffers.
        self._head_bytes += len(data)
        if self._head_bytes > self.settings.max_head_bytes:
            self._head_too_large = True
            self.send_400_response("")

    def send_400_response(self, msg: str) -> None:
        """uvicorn's answer to a head it could not parse; ``431`` for one too large."""
        if not self._head_too_large:
            super().send_400_response(msg)
            return
        limit = self.settings.max_head_bytes
        self._refuse(b"431 Request Header Fields Too Large", f"request head over {limit} bytes\n")

    def handle_websocket_upgrade(self) -> None:
        """Hand over to the WebSocket protocol, which keeps the place until it closes."""
        super().handle_websocket_upgrade()
        self._disarm()
        self._upgraded = True
        socket_protocol = self.transport.get_protocol()
        closed = socket_protocol.connection_lost

        def lost(exc: Exception | None) -> None:
            self.book.release(self)
            closed(exc)

        socket_protocol.connection_lost = lost  # type: ignore[method-assign]

    def on_response_complete(self) -> None:
        """An idle keep-alive connection may be pushed out for a new one."""
        super().on_response_complete()
        if not self.transport.is_closing():
            self.book.mark_waiting(self)

    # Parser callbacks
    def on_message_begin(self) -> None:
        """A request's first byte: its head has ``head_timeout`` to end."""
        super().on_message_begin()
        self._in_head = True
        self._head_size = 0
        self._arm(self.settings.head_timeout, self._head_late)

    def on_url(self, url: bytes) -> None:
        """Count the target towards ``max_head_bytes``."""
        self._count(len(url))
        super().on_url(url)

    def on_header(self, name: bytes, value: bytes) -> None:
        """Count the header towards ``max_head_bytes``."""
        self._count(len(name) + len(value) + 4)
        super().on_header(name, value)

    def on_headers_complete(self) -> None:
        """The head is in: no more head limits until the next request."""
        self._in_head = False
        self._head_bytes = 0
        self._disarm()
        self.book.mark_busy(self)
        super().on_headers_complete()

    # Limits
    def _count(self, size: int) -> None:
        self._head_size += size
        if self._head_size > self.settings.max_head_bytes:
            self._head_too_large = True
            raise _HeadTooLarge

    def _refuse(self, status: bytes, text: str) -> None:
        """Answer ``status`` and close. The answer is followed by our end of the stream and
        what the client still sends is read and dropped for a moment: closing at once with
        its data unread would reset the connection, and the client could lose the answer."""
        self._refused = True
        self._disarm()
        self.transport.write(_plain(status, text))
        if self.transport.can_write_eof():
            self.transport.write_eof()
            self._timer = self.loop.call_later(LINGER, self.transport.close)
        else:
            self.transport.close()

    def _arm(self, delay: float, callback: Any) -> None:
        self._disarm()
        self._timer = self.loop.call_later(delay, callback)

    def _disarm(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None

    def _idle(self) -> None:
        self._timer = None
        if self._in_head and not self.transport.is_closing():
            self.transport.close()

    def _head_late(self) -> None:
        self._timer = None
        if self._in_head and not self._refused and not self.transport.is_closing():
            self._refuse(b"408 Request Timeout", "request head too slow\n")

    def push_out(self) -> None:
        """Close this connection for a newer one (the server is at its limit)."""
        self._disarm()
        if not self.transport.is_closing():
            self.transport.close()


def guarded_http(settings: ConnectionSettings, book: ConnectionBook) -> type[GuardedHttp]:
    """uvicorn's ``http=`` class for one server: ``settings`` and ``book`` bound to it."""
    return type("GuardedHttp", (GuardedHttp,), {"settings": settings, "book": book})


def uvicorn_connection_options(settings: ConnectionSettings) -> dict[str, Any]:
    """Keyword arguments of ``uvicorn.Config`` for the limits of ``settings``."""
    book = ConnectionBook(connection_limit(settings.max_connections), settings.max_per_client)
    return {"http": guarded_http(settings, book)}
