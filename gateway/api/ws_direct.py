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
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

from websockets.protocol import State

__all__ = ["DirectWriter", "direct_writer", "text_frame"]

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


def direct_writer(send: Any) -> DirectWriter | None:
    """A direct writer for the connection whose ASGI ``send`` this is (see the module)."""
    protocol = _protocol_behind(send)
    if protocol is None or getattr(protocol.conn, "extensions", None):
        return None
    conn, transport, writable = protocol.conn, protocol.transport, protocol.writable

    def write(text: str) -> bool:
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
        return True

    return write
