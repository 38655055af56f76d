"""Fan-out without a task switch per client: a feed message written straight to the socket.

Through ASGI every message to every client is a wake of the client's sender task and a chain
of coroutines (Starlette's ``send_text``, the exception wrapper, uvicorn's ``send``) that
frames the same text again for each client: some 20 µs a client, 20 ms a change for 1,000
clients, which is the fan-out's p99 (bench/api.py).

``direct_writer`` finds, behind a connection's ASGI ``send``, uvicorn's sans-I/O WebSocket
protocol (``uvicorn[standard]``'s default); the writer it returns puts a text frame, built
once per message for all clients (``text_frame``), on that connection's transport at once,
in the publisher's own call. It writes only while nothing else is pending for the client:
the handshake is done, no close has been sent or received, the transport takes data
(``writable``, nothing buffered: a client that stops reading soon has bytes waiting, and
from then on its messages queue, so the backlog limit still drops it) and no per-message
extension is in use (deflate is off: ``uvicorn_ws_options``). Otherwise it answers False
and the message takes the ordinary path: the client's queue and its sender task. A server
other than uvicorn's sans-I/O protocol gets no writer, and everything takes that path.

What it reads of uvicorn is not uvicorn's public API, so it fails safe: the protocol must have
every attribute the writer reads, of the type it expects (``_usable``), or there is no writer;
and a writer that meets anything unexpected while it writes (an attribute gone, a transport
that raises) answers False for that message and every later one, logs it once, and the
connection goes on through its ASGI ``send`` (tests/api/test_ws_direct.py).
"""

from __future__ import annotations

import asyncio
import logging
import struct
from collections.abc import Callable
from typing import Any

from websockets.protocol import Protocol, State

__all__ = ["DirectWriter", "direct_writer", "text_frame"]

log = logging.getLogger("gateway.api")

#: Write one message's JSON text now; False: not now (queue it).
DirectWriter = Callable[[str], bool]

_PROTOCOL = "WebSocketsSansIOProtocol"
_last: tuple[str, bytes] = ("", b"\x81\x00")


def text_frame(text: str) -> bytes:
    """The unmasked, unfragmented text frame a server sends (RFC 6455 §5.2), made once for
    the message the feed hands to every client in turn (the same ``str`` object)."""
    global _last
    if _last[0] is text:
        return _last[1]
    payload = text.encode()
    size = len(payload)
    if size < 126:
        header = bytes((0x81, size))
    elif size < 1 << 16:
        header = struct.pack("!BBH", 0x81, 126, size)
    else:
        header = struct.pack("!BBQ", 0x81, 127, size)
    frame = header + payload
    _last = (text, frame)
    return frame


def _protocol_behind(send: Any) -> Any | None:
    """uvicorn's protocol object whose bound ``send`` the ASGI ``send`` wraps, if any."""
    stack, seen = [send], 0
    while stack and seen < 32:
        fn = stack.pop()
        seen += 1
        owner = getattr(fn, "__self__", None)
        if owner is not None and type(owner).__name__ == _PROTOCOL:
            return owner
        for cell in getattr(fn, "__closure__", None) or ():
            try:
                value = cell.cell_contents
            except ValueError:  # an empty cell
                continue
            if callable(value):
                stack.append(value)
    return None


def _usable(protocol: Any) -> bool:
    """True when ``protocol`` has what the writer reads, as the writer reads it."""
    try:
        return (
            isinstance(protocol.conn, Protocol)
            and not protocol.conn.extensions  # deflate would need a frame per client
            # uvloop's transports are not asyncio.Transport subclasses: what it does counts.
            and all(
                callable(getattr(protocol.transport, name, None))
                for name in ("write", "is_closing", "get_write_buffer_size")
            )
            and isinstance(protocol.writable, asyncio.Event)
            and isinstance(protocol.close_sent, bool)
            and isinstance(protocol.disconnected, bool)
        )
    except AttributeError:
        return False


def direct_writer(send: Any) -> DirectWriter | None:
    """A direct writer for the connection whose ASGI ``send`` this is (see the module)."""
    protocol = _protocol_behind(send)
    if protocol is None or not _usable(protocol):
        return None
    conn, transport, writable = protocol.conn, protocol.transport, protocol.writable
    broken = False

    def write(text: str) -> bool:
        nonlocal broken
        if broken:
            return False
        try:
            if (
                protocol.close_sent
                or protocol.disconnected
                or not writable.is_set()
                or conn.state is not State.OPEN
                or transport.is_closing()
                or transport.get_write_buffer_size()
            ):
                return False
            transport.write(text_frame(text))
        except Exception:
            # Nothing of this frame went out (a transport writes all or raises): the message
            # takes the ASGI path, and so does every later one.
            broken = True
            log.warning(
                "WebSocket direct write failed; this client goes through ASGI send", exc_info=True
            )
            return False
        return True

    return write
