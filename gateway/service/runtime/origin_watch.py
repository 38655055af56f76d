"""Tells everyone when an axis's origin is lost or found: an event, a log line (and, through
the event, an audit entry: ``gateway.api.audit.origin_entry``).

The state cache decides (``gateway.bus.origin``: a controller reset loses both origins of the
controller, an origin search that ends finds one); this follows its changes, so the event goes
out as the change is made, in the same turn of the event loop.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Awaitable, Callable
from types import MappingProxyType

from gateway.bus.state import StateCache
from gateway.bus.state_types import Change, Origin
from gateway.service.events import EventKind, ServiceEvent, ServiceEvents
from gateway.service.topology import AxisRef, Topology

__all__ = ["OriginWatch"]

log = logging.getLogger("gateway.origin")


class OriginWatch:
    """Publishes ``origin`` events and log lines from the state cache's changes; reads a
    position again at once when one reading of 0 makes a reset likely (``read_position``:
    how, None for never)."""

    def __init__(
        self,
        topology: Topology,
        cache: StateCache,
        events: ServiceEvents,
        read_position: Callable[[AxisRef], Awaitable[object]] | None = None,
    ) -> None:
        self.cache = cache
        self.events = events
        self.read_position = read_position
        self._axes: dict[tuple[str, str, int], AxisRef] = {
            (a.loop, a.body, a.motor): a for a in topology.axes()
        }
        self._reads: set[asyncio.Task[None]] = set()
        self.stop = cache.changes.subscribe(self._on_change)

    def _on_change(self, change: Change) -> None:
        if change.values.get("zero_from") is not None:
            self._read_again(change)
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

    def _read_again(self, change: Change) -> None:
        """A counter read 0 by itself: one more reading tells a reset from noise, now rather
        than at the poller's next idle read (seconds away)."""
        ref = self._axes.get((change.loop, change.body or "", change.motor or 0))
        if ref is None or self.read_position is None:
            return
        read = self.read_position

        async def again(axis: AxisRef) -> None:
            try:
                await read(axis)
            except Exception as exc:  # the poller reads it later anyway
                log.info("axis %s: position not read again: %s", axis.id, exc)

        try:
            task = asyncio.get_running_loop().create_task(again(ref))
        except RuntimeError:  # no event loop runs (a cache fed by hand): nothing to read with
            return
        self._reads.add(task)
        task.add_done_callback(self._reads.discard)
