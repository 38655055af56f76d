"""What protects the edge node's MQTT session from the outside: oversized payloads, and a
second node with the same Sparkplug id.

Payloads: a message over ``max_payload`` bytes is dropped before it is decoded (a DCMD with
200,000 metrics would otherwise be parsed, audited and logged), counted, and logged once per
``LOG_INTERVAL`` with the count since the last line.

Duplicates: two gateways configured with the same group and edge node id share a client id,
so each connection takes the other's MQTT session over. Some brokers say so (MQTT 5
DISCONNECT reason ``0x8E``, "Session taken over"); mosquitto 2.0 just closes the older
connection, so a session the broker ends within ``STABLE_SESSION`` of its start, the second
time in a row, counts as taken over too (a broker restart ends one session, and the
reconnection then fails until it is back). With different client ids each node sees an
NBIRTH on its own topic that it did not send (subscribed with MQTT 5's no-local option, so
its own never comes back). Either way the node logs an error naming the id, counts it, and
waits longer each time (``Backoff``), so the two do not fight at the reconnection rate.
"""

from __future__ import annotations

import logging
import random
import time
from dataclasses import dataclass, field

from aiomqtt import MqttCodeError

__all__ = [
    "LOG_INTERVAL",
    "SESSION_TAKEN_OVER",
    "Backoff",
    "DuplicateNode",
    "PayloadBound",
    "taken_over",
]

log = logging.getLogger("gateway.mqtt")

#: MQTT 5 DISCONNECT reason code "Session taken over": another client with our client id.
SESSION_TAKEN_OVER = 0x8E
#: Seconds between two log lines about dropped payloads.
LOG_INTERVAL = 60.0
#: The longest wait after repeated takeovers (seconds).
TAKEOVER_WAIT_MAX = 300.0
#: A session that lasted this long (seconds) ends a run of takeovers.
STABLE_SESSION = 60.0


class DuplicateNode(Exception):
    """Another edge node publishes under this node's Sparkplug id."""


def taken_over(exc: BaseException) -> bool:
    """Whether ``exc`` (or what caused it) is the broker's "Session taken over"."""
    seen: BaseException | None = exc
    for _ in range(5):
        if seen is None:
            return False
        if (
            isinstance(seen, MqttCodeError)
            and getattr(seen.rc, "value", seen.rc) == SESSION_TAKEN_OVER
        ):
            return True
        seen = seen.__cause__ or seen.__context__
    return False


@dataclass
class PayloadBound:
    """Drops payloads over ``limit`` bytes: counted, logged once per interval."""

    limit: int
    dropped: int = 0
    _unlogged: int = 0
    _logged_at: float = field(default=-LOG_INTERVAL)

    def allows(self, where: str, size: int) -> bool:
        """False (and counted) when a payload of ``size`` bytes on ``where`` is too big."""
        if size <= self.limit:
            return True
        self.dropped += 1
        self._unlogged += 1
        now = time.monotonic()
        if now - self._logged_at >= LOG_INTERVAL:
            log.warning(
                "mqtt: %d payload(s) over %d bytes dropped unread (the last: %d bytes on %s)",
                self._unlogged, self.limit, size, where,
            )  # fmt: skip
            self._unlogged, self._logged_at = 0, now
        return False


@dataclass
class Backoff:
    """The waits between connection attempts: ``first`` doubling to ``longest`` after
    failures, back to ``first`` once connected; after takeovers doubling to
    ``TAKEOVER_WAIT_MAX`` and not reset until a session lasts ``STABLE_SESSION``."""

    first: float
    longest: float
    wait: float = 0.0
    takeovers_in_row: int = 0
    #: sessions in a row the broker ended within ``STABLE_SESSION`` of their start
    short_losses: int = 0
    _since: float = 0.0

    def __post_init__(self) -> None:
        self.wait = self.first

    def connected(self) -> None:
        """A connection is up."""
        self._since = time.monotonic()
        if not self.takeovers_in_row:
            self.wait = self.first

    def session_lost(self) -> bool:
        """The broker ended a session of this attempt (call before ``next_wait``); True when
        it looks taken over: the second in a row to end within ``STABLE_SESSION``."""
        if not self._since:
            return False
        if time.monotonic() - self._since < STABLE_SESSION:
            self.short_losses += 1
        else:
            self.short_losses = 0
        return self.short_losses >= 2

    def next_wait(self, *, takeover: bool) -> float:
        """Seconds to wait now (jittered) after a session or an attempt ended."""
        lasted = time.monotonic() - self._since if self._since else 0.0
        self._since = 0.0
        if takeover:
            self.takeovers_in_row += 1
        elif lasted >= STABLE_SESSION:
            self.takeovers_in_row = 0
        base = self.wait
        self.wait = min(self.wait * 2, self.longest)
        if self.takeovers_in_row:
            longest = max(TAKEOVER_WAIT_MAX, self.longest)
            base = max(base, min(self.first * 2.0 ** min(self.takeovers_in_row, 30), longest))
        return base * random.uniform(0.5, 1.0)
