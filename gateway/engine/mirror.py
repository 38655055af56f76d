"""The API process's copy of a worker's state cache, fed by its numbered changes.

A ``StateMirror`` is a ``StateCache`` (the faces and service/ read it through the same
methods) that never decodes a reply: ``load`` takes a snapshot (on connect, and whenever a
change was missed), ``apply`` one change, which it publishes on ``changes`` as the worker's
cache did. A change whose number does not follow the last one is refused (``apply`` returns
False) and the caller asks for a snapshot: the mirror is never a mixture of two pasts.

Several workers feed one mirror (one per group of loops), each numbering its own changes:
the mirror keeps each worker's number apart (``source``) and numbers what it publishes
itself, so a reader of ``changes`` sees one gap-free sequence, as in one process.
"""

from __future__ import annotations

from dataclasses import replace
from types import MappingProxyType
from typing import Any

from gateway.bus.state import StateCache
from gateway.bus.state_types import AxisState, Change, ControllerState, LoopState, Snapshot

__all__ = ["StateMirror"]


class StateMirror(StateCache):
    """A state cache that follows other caches' changes instead of replies."""

    def __init__(self, *, stale_after: float = 3.0) -> None:
        super().__init__(stale_after=stale_after)
        #: per source (a worker), the number of its latest change applied (None: no snapshot)
        self._source_seq: dict[str, int | None] = {}

    def source_seq(self, source: str) -> int | None:
        """The number of ``source``'s latest change applied (None: no snapshot yet)."""
        return self._source_seq.get(source)

    def forget(self, source: str) -> None:
        """``source`` went away: its next change is refused until a snapshot comes."""
        self._source_seq[source] = None

    def load(self, source: str, snapshot: Snapshot) -> None:
        """Take ``source``'s loops as ``snapshot`` has them (changes published for each record
        that differs, so followers of ``changes`` catch up)."""
        for name, loop in snapshot.loops.items():
            self._replace(self._loops, name, loop, (name, None, None), LoopState(name))
        for (name, body), ctl in snapshot.controllers.items():
            key2 = (name, body)
            self._replace(self._ctls, key2, ctl, (name, body, None), ControllerState(body))
        for (name, body, motor), axis in snapshot.axes.items():
            key3 = (name, body, motor)
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
        if change.body is None:
            store, key, blank = self._loops, change.loop, LoopState(change.loop)
        elif change.motor is None:
            store, key = self._ctls, (change.loop, change.body)
            blank = ControllerState(change.body)
        else:
            store, key = self._axes, (change.loop, change.body, change.motor)
            blank = AxisState(change.motor)
        store[key] = replace(store.get(key, blank), **change.values)
        self._publish(change.time, change.loop, change.body, change.motor, change.values)
        return True

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
