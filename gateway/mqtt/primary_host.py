"""The Primary Host Application's ``STATE``, as an edge node follows it (Sparkplug 3.0).

A node configured with a primary host subscribes to ``spBv1.0/STATE/<host_id>`` (QoS 1; the
host keeps it retained) and publishes its births only once the host says
``{"online": true, "timestamp": <ms>}``. A later ``online: false`` whose timestamp is not
older than the last ``online: true`` means the host is gone: the node publishes its NDEATH and
disconnects, then connects again and waits for the host. Messages older than the newest one
seen are ignored (a stale retained message, a host's will arriving late), as the
specification asks ("Primary Host Application", STATE messages and Edge Node session
establishment).
"""

from __future__ import annotations

import json
from dataclasses import dataclass

from gateway.mqtt.sparkplug import NAMESPACE

__all__ = ["PrimaryHost", "state_topic"]


def state_topic(host_id: str) -> str:
    """``spBv1.0/STATE/<host_id>``."""
    return f"{NAMESPACE}/STATE/{host_id}"


@dataclass
class PrimaryHost:
    """What the node knows of its primary host: online or not, as of ``timestamp`` (ms)."""

    host_id: str
    online: bool = False
    timestamp: int = -1

    @property
    def topic(self) -> str:
        """The host's STATE topic."""
        return state_topic(self.host_id)

    def receive(self, payload: bytes) -> bool:
        """Apply one STATE payload; True when it changed ``online``. ``ValueError`` when it
        is not ``{"online": bool, "timestamp": int}``."""
        try:
            state = json.loads(payload)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ValueError(f"STATE of {self.host_id!r} is not JSON ({exc})") from None
        if not isinstance(state, dict):
            raise ValueError(f"STATE of {self.host_id!r}: a JSON object expected")
        online, stamp = state.get("online"), state.get("timestamp")
        if not isinstance(online, bool):
            raise ValueError(f"STATE of {self.host_id!r}: 'online' must be true or false")
        if not isinstance(stamp, int) or isinstance(stamp, bool) or stamp < 0:
            raise ValueError(f"STATE of {self.host_id!r}: 'timestamp' must be ms since 1970")
        if stamp < self.timestamp:
            return False  # older than what the node acted on: ignored
        changed = online != self.online
        self.online, self.timestamp = online, stamp
        return changed
