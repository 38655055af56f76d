"""The gateway's latched picture of every loop, controller and axis (DESIGN invariants 4, 9).

The cache only listens: the loop scheduler publishes every reply it decodes (its own
read-backs and the poller's polls included) and the cache turns them into state. Three
rules shape it:

* Reads that clear device flags (``""``, ``9`` form I, ``GSS``) are made by the scheduler
  alone; what they report is **latched** here until a client acknowledges it, so no error is
  lost because the poller or another client read it first (§10 "" 注意点, §10 9 ①, §10 GSS).
* ``""`` and ``9`` describe the controller, not a motor; which axis shows a latched error is
  decided in ``latches`` (docs/manual-notes.md, "Latched errors and axes").
* Every change gets the next sequence number and a timestamp, is kept in a bounded history
  and is published to subscribers; a subscriber that fell behind asks for the changes since
  its last number, or takes a fresh snapshot when the history no longer reaches back.

Times are whatever the caller stamps events with (the scheduler's clock); nothing here reads
a clock of its own.

Here: the cache. Its records are in ``state_types``, numbering, history and subscriptions
in ``changes`` (``ChangeLog``), what one reply tells in ``readings``, the latch rules in
``latches``.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Iterable, Mapping
from dataclasses import replace
from types import MappingProxyType
from typing import Any

from gateway.bus.changes import ChangeLog, FellBehind, Subscription
from gateway.bus.events import (
    BusEvent,
    ControllerAnswering,
    FramingChanged,
    LinkDown,
    LinkUp,
    ReplyObserved,
    SelectionChanged,
    TransactionDone,
)
from gateway.bus.latches import error_motor, latch_errors, unlatch
from gateway.bus.readings import apply_reply
from gateway.bus.state_types import (
    AXIS_ERRORS,
    MOTORS,
    AxisState,
    Change,
    ControllerState,
    ErrorKind,
    Latch,
    LoopState,
    Snapshot,
)
from gateway.protocol.framing import Framing
from gateway.protocol.models import Command
from gateway.protocol.replies import ReplyValue

__all__ = [
    "MOTORS",
    "AxisState",
    "Change",
    "ControllerState",
    "ErrorKind",
    "FellBehind",
    "Latch",
    "LoopState",
    "Snapshot",
    "StateCache",
    "Subscription",
]

log = logging.getLogger("gateway.bus")


class StateCache(ChangeLog):
    """The latched state of every loop; fed with replies, read by snapshot, change or stream."""

    def __init__(self, *, history: int = 10_000, stale_after: float = 3.0) -> None:
        super().__init__(history)
        self.stale_after = stale_after
        self._loops: dict[str, LoopState] = {}
        self._ctls: dict[tuple[str, str], ControllerState] = {}
        self._axes: dict[tuple[str, str, int], AxisState] = {}
        self._counters_published: dict[str, float] = {}
        #: per controller, the errors ``""`` reported since the last ``9`` form I read (the
        #: controller holds them in both stores, §10 9 ③: ``readings``)
        self.status_since_condition: dict[tuple[str, str], frozenset[ErrorKind]] = {}
        self.counters_period = 1.0
        self._followers: list[Callable[[BusEvent], None]] = []

    # ------------------------------------------------------------------ reading
    # (seq, changes_since, subscribe and listen: see ChangeLog)

    def loop(self, name: str) -> LoopState:
        """One loop (a blank one if nothing was heard of it)."""
        return self._loops.get(name) or LoopState(name)

    def controller(self, loop: str, body: str) -> ControllerState:
        """One controller (a blank one if nothing was heard of it)."""
        return self._ctls.get((loop, body)) or ControllerState(body)

    def axis(self, loop: str, body: str, motor: int) -> AxisState:
        """One axis (a blank one if nothing was heard of it)."""
        return self._axes.get((loop, body, motor)) or AxisState(motor)

    def bodies(self, loop: str) -> list[str]:
        """The controllers of ``loop`` the cache knows, in body order."""
        return sorted(b for (name, b) in self._ctls if name == loop)

    def snapshot(self) -> Snapshot:
        """Everything, with the sequence number to ask ``changes_since`` from next."""
        return Snapshot(
            self._seq,
            MappingProxyType(dict(self._loops)),
            MappingProxyType(dict(self._ctls)),
            MappingProxyType(dict(self._axes)),
        )

    # ------------------------------------------------------------------ writing

    def _set(
        self,
        store: dict[Any, Any],
        where: tuple[str, str | None, int | None],
        old: Any,
        now: float,
        **values: Any,
    ) -> None:
        """Store ``old`` with ``values`` under ``where`` and publish the fields that changed;
        a change of ``updated`` alone is stored silently (it moves with every poll)."""
        key = where[0] if where[1] is None else where[:2] if where[2] is None else where
        changed = {k: v for k, v in values.items() if getattr(old, k) != v}
        if not changed:
            store.setdefault(key, old)
            return
        store[key] = replace(old, **changed)
        if set(changed) - {"updated"}:
            self._emit(now, *where, **changed)

    def _set_loop(self, now: float, name: str, **values: Any) -> None:
        self._set(self._loops, (name, None, None), self.loop(name), now, **values)

    def _set_ctl(self, now: float, loop: str, body: str, **values: Any) -> None:
        if (loop, body) not in self._ctls:
            for m in MOTORS:
                self._axes[loop, body, m] = AxisState(m)
        self._set(self._ctls, (loop, body, None), self.controller(loop, body), now, **values)
        self._derive_axes(now, loop, body)

    def _set_axis(self, now: float, loop: str, body: str, motor: int, **values: Any) -> None:
        self._set(self._axes, (loop, body, motor), self.axis(loop, body, motor), now, **values)

    def _derive_axes(self, now: float, loop: str, body: str) -> None:
        """The axis fields that follow from the controller: moving, selected, errors."""
        ctl = self._ctls[loop, body]
        moving_motor = ctl.selected_motor if ctl.moving else None
        for m in MOTORS:
            shows = {k: m in ctl.latched[k].axes for k in AXIS_ERRORS if k in ctl.latched}
            step_out = bool(ctl.condition_bits.get(6)) and error_motor(ctl) in (None, m)
            self._set_axis(
                now,
                loop,
                body,
                m,
                moving=moving_motor == m,
                selected=ctl.selected_motor == m,
                step_out=step_out,
                limit_error=shows.get(ErrorKind.LIMIT, False),
                emergency=shows.get(ErrorKind.EMERGENCY, False),
                command_error=shows.get(ErrorKind.COMMAND, False),
            )

    def _latch(
        self, now: float, loop: str, body: str, kinds: Iterable[ErrorKind], source: str
    ) -> None:
        ctl = self.controller(loop, body)
        latched = latch_errors(ctl, kinds, now, source)
        if latched != ctl.latched:
            self._set_ctl(now, loop, body, latched=MappingProxyType(latched))

    def acknowledge(
        self,
        loop: str,
        body: str,
        now: float,
        *,
        motor: int | None = None,
        kinds: Iterable[ErrorKind] | None = None,
    ) -> list[ErrorKind]:
        """A client has seen the latched errors: clear them (those of ``kinds``; all if None).

        With ``motor`` only that axis stops showing them; an error clears from the controller
        when no axis shows it any more (controller-only kinds need a controller acknowledge).
        Returns the kinds that are no longer latched.
        """
        ctl = self.controller(loop, body)
        latched, cleared = unlatch(ctl.latched, motor=motor, kinds=kinds)
        if latched != ctl.latched:
            self._set_ctl(now, loop, body, latched=MappingProxyType(latched))
        return cleared

    def observe(
        self,
        loop: str,
        body: str,
        command: Command,
        value: ReplyValue | None,
        time: float,
        *,
        motor: int | None = None,
        rejected: bool = False,
    ) -> None:
        """One decoded reply of ``body`` to ``command``: ``value`` is the typed data, None for
        '>' (or '>@' with ``rejected``); ``motor`` the scheduler's word on the motor a
        command without a suffix acted on."""
        apply_reply(self, loop, body, command, value, time, motor=motor, rejected=rejected)

    def follow(self, callback: Callable[[BusEvent], None]) -> Callable[[], None]:
        """Call ``callback(event)`` with every scheduler event the cache takes, right after
        it has learnt from it; returns the unsubscribe. A subscriber that reads the cache
        while it handles an event follows here: it reads what that event taught, whatever
        order the scheduler's subscribers were added in."""
        self._followers.append(callback)
        return lambda: self._followers.remove(callback) if callback in self._followers else None

    def handle(self, event: BusEvent, *, queue_depth: int | None = None) -> None:
        """Take one event of the loop scheduler (subscribe this to its ``EventBus``), then
        hand it to the followers; ``queue_depth``: the scheduler's, if the subscriber knows it."""
        try:
            self._learn(event, queue_depth)
        finally:
            for callback in list(self._followers):
                try:
                    callback(event)
                except Exception:  # one bad follower must not stop the others
                    log.exception("state follower %r failed on %r", callback, event)

    def _learn(self, event: BusEvent, queue_depth: int | None) -> None:
        if isinstance(event, ReplyObserved):
            self.observe(
                event.loop,
                event.body,
                event.command,
                event.value,
                event.time,
                motor=event.motor,
                rejected=event.rejected,
            )
        elif isinstance(event, LinkUp):
            self.set_link(event.loop, True, event.time)
        elif isinstance(event, LinkDown):
            self.set_link(event.loop, False, event.time, event.cause)
        elif isinstance(event, TransactionDone):
            counters = dataclasses.asdict(event.counters)
            self.set_loop_stats(event.loop, event.time, counters=counters, queue_depth=queue_depth)
        elif isinstance(event, FramingChanged):
            self.set_framing(event.loop, event.body, event.framing, event.time)
        elif isinstance(event, ControllerAnswering):
            self.set_online(event.loop, event.body, event.online, event.time)
        elif isinstance(event, SelectionChanged):
            # The scheduler's word: None, in doubt; a motor, read back or executed under ER1.
            confirmed = {"selection_confirmed": event.motor is not None}
            motor = {} if event.motor is None else {"selected_motor": event.motor}
            self._set_ctl(event.time, event.loop, event.body, **confirmed, **motor)

    def set_link(self, loop: str, up: bool, now: float, cause: str | None = None) -> None:
        """The loop went up or down. Down: every controller's data is stale; up: nothing is
        restored, the poller reads every controller again. What was read from the line while
        it came back (the scheduler's probes, ``97``: the selection) is current, and kept."""
        self._set_loop(now, loop, up=up, cause=None if up else cause)
        if up:
            return
        for name, body in [k for k in self._ctls if k[0] == loop]:
            # Nothing a silent loop said is current: not even that a motor moves (a moving
            # flag that outlived the line would answer requests as a busy controller).
            self._set_ctl(
                now,
                name,
                body,
                online=None,
                moving=False,
                selection_confirmed=False,
                signed_positions=None,
            )
            for m in MOTORS:
                self._set_axis(now, name, body, m, stale=True)

    def set_online(self, loop: str, body: str, online: bool, now: float) -> None:
        """The poller found the controller answering (or not): off and back, it has reloaded
        its settings from the EEPROM (§16), EP among them."""
        self._set_ctl(now, loop, body, online=online, signed_positions=None)
        if not online:  # switched off: nothing moves; power-on resets the selection (§16)
            self._set_ctl(now, loop, body, moving=False, selection_confirmed=False)
            for m in MOTORS:
                self._set_axis(now, loop, body, m, stale=True)

    def set_framing(self, loop: str, body: str, framing: Framing, now: float) -> None:
        """The framing the scheduler uses for the controller (it owns EE/EL/ER/SUM)."""
        self._set_ctl(now, loop, body, framing=framing)

    def set_loop_stats(
        self,
        loop: str,
        now: float,
        *,
        counters: Mapping[str, float],
        queue_depth: int | None = None,
    ) -> None:
        """The scheduler's counters (and queue depth); published at most every
        ``counters_period`` seconds so a busy line does not flood the history."""
        last = self._counters_published.get(loop)
        if last is not None and now - last < self.counters_period:
            return
        self._counters_published[loop] = now
        depth = {} if queue_depth is None else {"queue_depth": queue_depth}
        self._set_loop(now, loop, counters=MappingProxyType(dict(counters)), **depth)

    def refresh(self, now: float) -> None:
        """Mark the axes without fresh data for ``stale_after`` seconds stale."""
        for (loop, body, m), axis in list(self._axes.items()):
            old = axis.updated is None or now - axis.updated > self.stale_after
            if old and not axis.stale:
                self._set_axis(now, loop, body, m, stale=True)
