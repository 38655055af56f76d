"""The state cache's records and their numbering (DESIGN invariant 9).

One ``LoopState`` per loop, one ``ControllerState`` per controller and one ``AxisState`` per
axis, each replaced whole when a field changes (the records are frozen). Every change gets the
next sequence number and is published on ``changes`` (an ``EventBus``: callbacks, run as the
change is made) with the fields that moved; the records keep no history: a reader that needs
what it missed takes a ``snapshot``. The axis fields that follow from their controller's record
(moving, selected, the latched errors it shows) are derived here as it changes, and an axis
whose data is older than ``stale_after`` seconds is marked stale (``refresh``).

Times are whatever the caller stamps them with; nothing here reads a clock of its own. What
the records are written from (the scheduler's events and replies) is ``gateway.bus.state``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from types import MappingProxyType
from typing import Any, TypeVar

from gateway.bus.events import EventBus
from gateway.bus.latches import error_motor
from gateway.bus.origin import axis_moving
from gateway.bus.state_types import (
    AXIS_ERRORS,
    MOTORS,
    AxisState,
    Change,
    ControllerState,
    ErrorKind,
    LoopState,
    Snapshot,
)

__all__ = ["StateRecords"]

_R = TypeVar("_R", LoopState, ControllerState, AxisState)


class StateRecords:
    """Every loop's, controller's and axis's record; each change numbered and published."""

    def __init__(self, *, stale_after: float = 3.0) -> None:
        #: every change as it is made, numbered (``seq``): ``changes.subscribe(callback)``
        self.changes: EventBus[Change] = EventBus()
        self._seq = 0
        self.stale_after = stale_after
        self._loops: dict[str, LoopState] = {}
        self._ctls: dict[tuple[str, str], ControllerState] = {}
        self._axes: dict[tuple[str, str, int], AxisState] = {}
        #: the ``updated`` of controllers and axes whose latest reply changed nothing else
        #: (``_fold``), by their keys: (loop, body) and (loop, body, motor)
        self._fresh: dict[tuple[str, str] | tuple[str, str, int], float] = {}
        #: no axis that is not stale was updated before this (``refresh`` walks the axes only
        #: once the oldest of them may have turned stale; -inf: not known, walk)
        self._oldest_fresh = -math.inf

    # ------------------------------------------------------------------ reading

    @property
    def seq(self) -> int:
        """The number of the latest change (0: none yet)."""
        return self._seq

    def loop(self, name: str) -> LoopState:
        """One loop (a blank one if nothing was heard of it)."""
        return self._fold(self._loops, name) or LoopState(name)

    def controller(self, loop: str, body: str) -> ControllerState:
        """One controller (a blank one if nothing was heard of it)."""
        return self._fold(self._ctls, (loop, body)) or ControllerState(body)

    def flags(self, loop: str, body: str) -> ControllerState:
        """One controller as last changed, without the time of its latest reply (``updated``
        may lag behind): for readers that ask what it does many times a poll (the poller),
        so that an idle poll copies no record."""
        return self._ctls.get((loop, body)) or ControllerState(body)

    def axis(self, loop: str, body: str, motor: int) -> AxisState:
        """One axis (a blank one if nothing was heard of it)."""
        return self._fold(self._axes, (loop, body, motor)) or AxisState(motor)

    def axis_flags(self, loop: str, body: str, motor: int) -> AxisState:
        """One axis as last changed, without the time of its latest reply (``flags``'s
        counterpart: for the rules a status poll runs on every axis, which copy no record)."""
        return self._axes.get((loop, body, motor)) or AxisState(motor)

    def bodies(self, loop: str) -> list[str]:
        """The controllers of ``loop`` the cache knows, in body order."""
        return sorted(b for (name, b) in self._ctls if name == loop)

    def latest_updates(self) -> dict[tuple[str, str] | tuple[str, str, int], float]:
        """Every controller's and axis's ``updated`` (the time of its latest reply, also of
        the replies that changed nothing else and so published nothing), by its key:
        (loop, body) or (loop, body, motor). Read without copying any record."""
        out: dict[tuple[str, str] | tuple[str, str, int], float] = {}
        for store in (self._ctls, self._axes):
            for key, record in store.items():
                updated = self._fresh.get(key, record.updated)
                if updated is not None:
                    out[key] = updated
        return out

    def snapshot(self) -> Snapshot:
        """Everything, as of change ``seq`` (a later change has a higher number)."""
        for key in list(self._fresh):
            # (loop, body, motor): an axis; (loop, body): a controller (a loop has no reply time)
            store: dict[Any, Any] = self._axes if len(key) == 3 else self._ctls
            self._fold(store, key)
        return Snapshot(
            self._seq,
            MappingProxyType(dict(self._loops)),
            MappingProxyType(dict(self._ctls)),
            MappingProxyType(dict(self._axes)),
        )

    # ------------------------------------------------------------------ writing
    # ``updated`` moves with every reply: it is kept in ``_fresh`` and folded into the record
    # when someone reads it, so that a poll that changes nothing else copies no record.

    def _fold(self, store: dict[Any, _R], key: Any) -> _R | None:
        """The record under ``key`` with its latest ``updated`` (stored, if it was behind)."""
        record = store.get(key)
        if record is not None and key in self._fresh:
            record = store[key] = replace(record, updated=self._fresh.pop(key))
        return record

    def _set(
        self,
        store: dict[Any, _R],
        key: Any,
        where: tuple[str, str | None, int | None],
        blank: Callable[[], _R],
        now: float,
        **values: Any,
    ) -> bool:
        """Store the record under ``key`` (``blank()`` if none) with ``values`` and publish
        the fields that changed; a change of ``updated`` alone is kept silently (see above).
        True when the record changed."""
        updated = values.pop("updated", None)
        old = store.get(key)
        if old is None:
            old = store[key] = blank()
        if updated is not None:
            self._fresh[key] = updated
            if updated < self._oldest_fresh:  # an older reading than any known: walk again
                self._oldest_fresh = -math.inf
        changed = {k: v for k, v in values.items() if getattr(old, k) != v}
        if not changed:
            return False
        if updated is not None:  # published with the fields that changed, as it was read
            changed["updated"] = self._fresh.pop(key)
        store[key] = replace(old, **changed)
        if changed.get("stale") is False:  # fresh again: ``refresh`` must watch it (walk)
            self._oldest_fresh = -math.inf
        self._seq += 1
        loop, body, motor = where
        self.changes.publish(Change(self._seq, now, loop, body, motor, MappingProxyType(changed)))
        return True

    def _set_loop(self, now: float, name: str, **values: Any) -> None:
        self._set(self._loops, name, (name, None, None), lambda: LoopState(name), now, **values)

    def write_controller(self, now: float, loop: str, body: str, **values: Any) -> None:
        """Set fields of one controller (and the axis fields that follow from them)."""
        new = (loop, body) not in self._ctls
        if new:
            for m in MOTORS:
                self._axes[loop, body, m] = AxisState(m)
        blank = lambda: ControllerState(body)  # noqa: E731
        changed = self._set(self._ctls, (loop, body), (loop, body, None), blank, now, **values)
        if changed or new:  # the axes follow the controller's record, not the time of a reply
            self._derive_axes(now, loop, body)

    def write_axis(self, now: float, loop: str, body: str, motor: int, **values: Any) -> None:
        """Set fields of one axis."""
        key = (loop, body, motor)
        self._set(self._axes, key, key, lambda: AxisState(motor), now, **values)

    def _derive_axes(self, now: float, loop: str, body: str) -> None:
        """The axis fields that follow from the controller: moving, selected, errors."""
        ctl = self._ctls[loop, body]  # its updated does not matter here
        for m in MOTORS:
            shows = {k: m in ctl.latched[k].axes for k in AXIS_ERRORS if k in ctl.latched}
            step_out = bool(ctl.condition_bits.get(6)) and error_motor(ctl) in (None, m)
            self.write_axis(
                now,
                loop,
                body,
                m,
                moving=axis_moving(ctl, m),
                selected=ctl.selected_motor == m,
                step_out=step_out,
                limit_error=shows.get(ErrorKind.LIMIT, False),
                emergency=shows.get(ErrorKind.EMERGENCY, False),
                command_error=shows.get(ErrorKind.COMMAND, False),
            )

    def refresh(self, now: float) -> None:
        """Mark the axes without fresh data for ``stale_after`` seconds stale.

        Called after every poll, it walks the axes only once the oldest reading among the
        axes not stale may be too old (the same test as for each axis, on the oldest): an
        idle poll of a loop whose axes are all fresh costs one comparison."""
        if now - self._oldest_fresh <= self.stale_after:
            return
        self._oldest_fresh = math.inf  # lowered by what turns fresh during the walk too
        oldest = math.inf
        for key, axis in list(self._axes.items()):
            if axis.stale:
                continue
            loop, body, m = key
            updated = self._fresh.get(key, axis.updated)
            if updated is None or now - updated > self.stale_after:
                self.write_axis(now, loop, body, m, stale=True)
            elif updated < oldest:
                oldest = updated
        self._oldest_fresh = min(self._oldest_fresh, oldest)
