"""systemd's readiness protocol (sd_notify(3)) without libsystemd: one datagram to
``$NOTIFY_SOCKET``. With ``Type=notify`` systemd counts the service as started when it
receives ``READY=1`` (deploy/systemd/rc233-gateway.service); elsewhere nothing is sent.
"""

from __future__ import annotations

import os
import socket

__all__ = ["notify"]


def notify(state: str) -> bool:
    """Send ``state`` (``READY=1``, ``STOPPING=1``, ``STATUS=...``); False when not under
    systemd. A datagram to a local socket: it does not wait on the receiver."""
    path = os.environ.get("NOTIFY_SOCKET")
    if not path:
        return False
    address = "\0" + path[1:] if path.startswith("@") else path  # abstract namespace
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.setblocking(False)
        sock.sendto(state.encode(), address)
    return True
