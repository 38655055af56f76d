"""The API process's copy of a worker's state cache, fed by its numbered changes.

A ``StateMirror`` is a ``StateCache`` (the faces and service/ read it through the same
methods) that never decodes a reply: ``load`` takes a snapshot (on connect, and whenever a
change was missed), ``apply`` one change, which it publishes on ``changes`` as the worker's
cache did. A change whose number does not follow the last one is refused (``apply`` returns
False) and the caller asks for a snapshot: the mirror is never a mixture of two pasts.

Several workers feed one mirror (one per group of loops), each numbering its own changes:
the mirror keeps each worker's number apart (``source``) and numbers what it publishes
itself, so a reader of ``changes`` sees one gap-free sequence, as in one process.

Latched errors outlive a worker: only a client's acknowledge clears one, and a worker that
died took its cache with it. ``hold(loops)`` (its loops' worker went away) keeps every latch
the mirror shows for them; a later worker's records (its snapshot, its changes) show those
held latches beside their own until the worker latches the same kind again (then its own
record carries it) or a client acknowledges it. ``acknowledge`` clears the mirror's record
at once and sends the acknowledge to the loop's worker (``route``), whose cache clears it
too and publishes the change.

``relay(event)`` hands a scheduler event (received after the changes it caused) to the
followers (``follow``), as the cache of one process does once it has learnt from it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import replace
from types import MappingProxyType
from typing import Any

from gateway.bus.events import BusEvent
from gateway.bus.latches import unlatch
from gateway.bus.state import StateCache
from gateway.bus.state_types import (
    AxisState,
    Change,
    ControllerState,
    ErrorKind,
    Latch,
    LoopState,
    Snapshot,
)

#: the acknowledge a worker is sent: (loop, body, motor, kinds)
AcknowledgeSink = Callable[[str, str, int | None, tuple[ErrorKind, ...] | None], None]

#: the axis fields that show a latched error of each kind (``StateCache._derive_axes``)
_AXIS_FLAGS = {
    ErrorKind.LIMIT: "limit_error",
    ErrorKind.EMERGENCY: "emergency",
    ErrorKind.COMMAND: "command_error",
}

__all__ = ["AcknowledgeSink", "StateMirror"]


class StateMirror(StateCache):
    """A state cache that follows other caches' changes instead of replies."""

    def __init__(self, *, stale_after: float = 3.0) -> None:
        super().__init__(stale_after=stale_after)
        #: per source (a worker), the number of its latest change applied (None: no snapshot)
        self._source_seq: dict[str, int | None] = {}
        #: per controller, the latches a worker that went away showed and no client has
        #: acknowledged since (a later worker's records show them beside their own)
        self._held: dict[tuple[str, str], dict[ErrorKind, Latch]] = {}
        #: per loop, where its acknowledges go (the loop's worker)
        self._sinks: dict[str, AcknowledgeSink] = {}

    def source_seq(self, source: str) -> int | None:
        """The number of ``source``'s latest change applied (None: no snapshot yet)."""
        return self._source_seq.get(source)

    def forget(self, source: str) -> None:
        """``source`` went away: its next change is refused until a snapshot comes."""
        self._source_seq[source] = None

    def route(self, loop: str, sink: AcknowledgeSink) -> None:
        """Send the acknowledges of ``loop``'s latches to ``sink`` (its worker)."""
        self._sinks[loop] = sink

    def relay(self, event: BusEvent) -> None:
        """Hand a scheduler event to the followers (the changes it caused are applied)."""
        self._followers.publish(event)

    def hold(self, loops: Iterable[str]) -> None:
        """The worker of ``loops`` went away: keep the latches shown for them until a client
        acknowledges them, whatever the next worker's records say."""
        names = set(loops)
        for (loop, body), ctl in self._ctls.items():
            if loop in names and ctl.latched:
                self._held.setdefault((loop, body), {}).update(ctl.latched)

    def held(self, loop: str, body: str) -> Mapping[ErrorKind, Latch]:
        """The latches of a controller kept from a worker that went away."""
        return MappingProxyType(self._held.get((loop, body), {}))

    def acknowledge(
        self,
        loop: str,
        body: str,
        now: float,
        *,
        motor: int | None = None,
        kinds: Iterable[ErrorKind] | None = None,
    ) -> list[ErrorKind]:
        """Clear the latches here at once (held ones too) and in the loop's worker."""
        wanted = None if kinds is None else tuple(kinds)
        held = self._held.get((loop, body))
        if held:
            left, _ = unlatch(held, motor=motor, kinds=wanted)
            self._held[loop, body] = left
        cleared = super().acknowledge(loop, body, now, motor=motor, kinds=wanted)
        sink = self._sinks.get(loop)
        if sink is not None:
            sink(loop, body, motor, wanted)
        return cleared

    def load(self, source: str, snapshot: Snapshot) -> None:
        """Take ``source``'s loops as ``snapshot`` has them (changes published for each record
        that differs, so followers of ``changes`` catch up)."""
        for name, loop in snapshot.loops.items():
            self._replace(self._loops, name, loop, (name, None, None), LoopState(name))
        for (name, body), ctl in snapshot.controllers.items():
            key2 = (name, body)
            ctl = replace(ctl, latched=self._with_held(name, body, ctl.latched))
            self._replace(self._ctls, key2, ctl, (name, body, None), ControllerState(body))
        for (name, body, motor), axis in snapshot.axes.items():
            key3 = (name, body, motor)
            flags: dict[str, Any] = self._held_flags(name, body, motor, _flags_of(axis))
            axis = replace(axis, **flags)
            self._replace(self._axes, key3, axis, key3, AxisState(motor))
        self._source_seq[source] = snapshot.seq

    def apply(self, source: str, change: Change) -> bool:
        """Apply one change of ``source``; False (nothing applied) when one was missed."""
        last = self._source_seq.get(source)
        if last is None or change.seq != last + 1:
            return False
        self._source_seq[source] = change.seq
        store: dict[Any, Any]
        key: Any
        blank: Any
        values: Mapping[str, Any] = change.values
        if change.body is None:
            store, key, blank = self._loops, change.loop, LoopState(change.loop)
        elif change.motor is None:
            store, key = self._ctls, (change.loop, change.body)
            blank = ControllerState(change.body)
            if "latched" in values:
                latched = self._with_held(change.loop, change.body, values["latched"])
                values = {**values, "latched": latched}
        else:
            store, key = self._axes, (change.loop, change.body, change.motor)
            blank = AxisState(change.motor)
            flags = {k: v for k, v in values.items() if k in _AXIS_FLAGS.values()}
            if flags:
                values = {**values, **self._held_flags(change.loop, change.body, change.motor,
                                                       flags)}  # fmt: skip
        store[key] = replace(store.get(key, blank), **values)
        self._publish(change.time, change.loop, change.body, change.motor, values)
        return True

    def _with_held(
        self, loop: str, body: str, latched: Mapping[ErrorKind, Latch]
    ) -> Mapping[ErrorKind, Latch]:
        """A worker's latches of a controller with the held ones beside them; a kind the
        worker latched again is its own from now on (no longer held)."""
        held = self._held.get((loop, body))
        if not held:
            return latched
        for kind in latched:
            held.pop(kind, None)
        return MappingProxyType({**held, **latched})

    def _held_flags(
        self, loop: str, body: str, motor: int, flags: Mapping[str, bool]
    ) -> dict[str, bool]:
        """An axis's error flags with those its controller's held latches show set."""
        held = self._held.get((loop, body))
        out = dict(flags)
        if held:
            for kind, name in _AXIS_FLAGS.items():
                if kind in held and motor in held[kind].axes and name in out:
                    out[name] = True
        return out

    def freshen(self, times: Mapping[Any, float]) -> None:
        """Move the ``updated`` of controllers and axes (keys as ``latest_updates``) forward,
        silently: the worker's replies that changed nothing else, which its cache keeps
        without publishing. A view's ``updated`` and age are then the worker's, as in one
        process."""
        for key, updated in times.items():
            store: dict[Any, Any] = self._axes if len(key) == 3 else self._ctls
            record = store.get(key)
            if record is None:
                continue
            known = self._fresh.get(key, record.updated)
            if known is None or known < updated:
                self._fresh.pop(key, None)
                store[key] = replace(record, updated=updated)

    def _replace(
        self,
        store: dict[Any, Any],
        key: Any,
        record: Any,
        where: tuple[str, str | None, int | None],
        blank: Any,
    ) -> None:
        old = store.get(key, blank)
        if old == record and key in store:
            return
        store[key] = record
        fields = {
            k: getattr(record, k)
            for k in record.__dataclass_fields__
            if getattr(old, k) != getattr(record, k)
        }
        if fields or old is blank:
            when = getattr(record, "updated", None) or 0.0
            self._publish(when, *where, fields)

    def _publish(
        self,
        when: float,
        loop: str,
        body: str | None,
        motor: int | None,
        values: Any,
    ) -> None:
        self._seq += 1
        self.changes.publish(
            Change(self._seq, when, loop, body, motor, MappingProxyType(dict(values)))
        )


def _flags_of(axis: AxisState) -> dict[str, bool]:
    return {name: bool(getattr(axis, name)) for name in _AXIS_FLAGS.values()}
