"""From configuration to a line: ``open_transport(url, baud)``, and the reconnect ``Backoff``.

``url`` is a device path (``/dev/ttyUSB0``, ``/dev/serial/by-id/...``), ``socket://HOST:PORT``
(a serial device server such as ser2net or a Moxa NPort in TCP-server mode) or
``rfc2217://HOST:PORT``. ``baud`` is one of the RC-233's rates (§2 仕様: 9600, 1200, 300 bps;
§10 ES); it sets the port's rate (device path, rfc2217) and the scheduler's timing of the line
(for ``socket://`` the device server's own setting must match it).
"""

from __future__ import annotations

import ipaddress
import os
import random
import urllib.parse
from dataclasses import dataclass, field
from typing import Any

from gateway.protocol.framing import BAUD_RATES
from gateway.transport.base import Transport
from gateway.transport.serial_line import LineKind, SerialLine

__all__ = ["BAUD_RATES", "Backoff", "line_identity", "open_transport"]


def open_transport(url: str, baud: int, **options: Any) -> Transport:
    """The ``Transport`` for ``url`` at ``baud`` (not opened yet: call ``open``).

    ``options`` go to ``SerialLine`` (``open_timeout``, ``close_timeout``, ``keepalive``).
    ``ValueError`` naming the field (``url`` or ``baud``) and what is allowed, for anything else.
    """
    if isinstance(baud, bool) or not isinstance(baud, int) or baud not in BAUD_RATES:
        raise ValueError(
            f"baud {baud!r}: the RC-233 talks at {', '.join(map(str, BAUD_RATES))} bps (§2, §10 ES)"
        )
    return SerialLine(url, baud, **options)


def line_identity(url: str) -> str:
    """What ``url`` reaches, so that two spellings of one line compare equal.

    A device path with its symbolic links resolved (``/dev/serial/by-id/...`` and the
    ``/dev/ttyUSB0`` it points to are one port). A network line as ``tcp://HOST:PORT``,
    whichever the scheme (``socket://`` and ``rfc2217://`` on one device-server port are one
    line), the host in lower case without a trailing dot and an IP address in its canonical
    form; names are not resolved (no DNS lookup), so ``localhost`` and ``127.0.0.1`` differ.
    ``ValueError`` as ``LineKind.of`` for a URL of none of the kinds.
    """
    if LineKind.of(url) is LineKind.DEVICE:
        return os.path.realpath(url)
    parts = urllib.parse.urlsplit(url)
    host = (parts.hostname or "").rstrip(".")
    try:
        address = ipaddress.ip_address(host)
    except ValueError:
        return f"tcp://{host}:{parts.port}"
    shown = f"[{address.compressed}]" if address.version == 6 else address.compressed
    return f"tcp://{shown}:{parts.port}"


@dataclass
class Backoff:
    """Delays between reconnection attempts: ``first``, growing by ``factor`` up to ``maximum``.

    Each delay is spread by up to ``jitter`` (a fraction, both ways) so that gateways that lost
    the same device server do not all come back in step. ``reset`` after a successful open.
    """

    first: float = 0.5
    maximum: float = 30.0
    factor: float = 2.0
    jitter: float = 0.1
    rng: random.Random = field(default_factory=random.Random, repr=False)
    attempts: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        if not 0 < self.first <= self.maximum:
            raise ValueError(
                f"backoff: need 0 < first <= maximum, not {self.first}, {self.maximum}"
            )
        if self.factor < 1 or not 0 <= self.jitter < 1:
            raise ValueError(
                f"backoff: need factor >= 1, 0 <= jitter < 1 ({self.factor}, {self.jitter})"
            )

    def next_delay(self) -> float:
        """Seconds to wait before the next attempt (and count the attempt)."""
        base = min(self.maximum, self.first * self.factor ** min(self.attempts, 64))
        self.attempts += 1
        spread = 1 + self.jitter * (2 * self.rng.random() - 1)
        return min(self.maximum, base * spread)

    def reset(self) -> None:
        """The line is back: the next failure starts again at ``first``."""
        self.attempts = 0
