"""Tells everyone when an axis's origin is lost or found: an event, a log line (and, through
the event, an audit entry: ``gateway.api.audit.origin_entry``).

The state cache decides (``gateway.bus.origin``: a controller reset loses both origins of the
controller, an origin search that ends finds one); this follows its changes, so the event goes
out as the change is made, in the same turn of the event loop.
"""

from __future__ import annotations

import logging
import time
from types import MappingProxyType

from gateway.bus.state import StateCache
from gateway.bus.state_types import Change, Origin
from gateway.service.events import EventKind, ServiceEvent, ServiceEvents
from gateway.service.topology import AxisRef, Topology

__all__ = ["OriginWatch"]

log = logging.getLogger("gateway.origin")


class OriginWatch:
    """Publishes ``origin`` events and log lines from the state cache's changes."""

    def __init__(self, topology: Topology, cache: StateCache, events: ServiceEvents) -> None:
        self.cache = cache
        self.events = events
        self._axes: dict[tuple[str, str, int], AxisRef] = {
            (a.loop, a.body, a.motor): a for a in topology.axes()
        }
        self.stop = cache.changes.subscribe(self._on_change)

    def _on_change(self, change: Change) -> None:
        origin = change.values.get("origin")
        if origin is None or change.body is None or change.motor is None:
            return
        ref = self._axes.get((change.loop, change.body, change.motor))
        if ref is None:
            return
        ctl = self.cache.flags(change.loop, change.body)
        lost = origin is Origin.LOST
        cause = (ctl.reset_cause or "controller reset") if lost else "origin search ended"
        data = {
            "axis": ref.id,
            "controller": ref.controller_id,
            "origin": Origin(origin).value,
            "homed": origin is Origin.HOMED,
            "cause": cause,
        }
        extra = {
            "event": f"origin_{data['origin']}",
            "axis": ref.id,
            "controller": ref.controller_id,
        }
        if lost:
            log.warning("axis %s: origin lost, home it first (%s)", ref.id, cause, extra=extra)
        else:
            log.info("axis %s: origin %s", ref.id, data["origin"], extra=extra)
        self.events.publish(
            ServiceEvent(EventKind.ORIGIN, f"axis:{ref.id}", time.time(), MappingProxyType(data))
        )
