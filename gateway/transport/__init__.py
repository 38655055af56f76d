"""The serial lines the loop scheduler talks through.

``open_transport(url, baud)`` turns configuration into a ``Transport``: a ``SerialLine`` for a
device path, ``socket://`` or ``rfc2217://``. ``PipeTransport`` is an in-process line to a peer
such as the simulator. Either raises ``TransportClosed`` from ``read``/``write`` as soon as the
line is lost; the scheduler reconnects, pacing itself with ``Backoff``.
"""

from gateway.transport.base import BufferedTransport, ReceiveBuffer, Transport, TransportClosed
from gateway.transport.factory import BAUD_RATES, Backoff, open_transport
from gateway.transport.pipe import Peer, PeerFactory, PipeTransport
from gateway.transport.serial_line import KeepAlive, LineKind, SerialLine

__all__ = [
    "BAUD_RATES",
    "Backoff",
    "BufferedTransport",
    "KeepAlive",
    "LineKind",
    "Peer",
    "PeerFactory",
    "PipeTransport",
    "ReceiveBuffer",
    "SerialLine",
    "Transport",
    "TransportClosed",
    "open_transport",
]
