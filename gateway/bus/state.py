"""The gateway's latched picture of every loop, controller and axis (DESIGN invariants 4, 9).

The cache only listens: the loop scheduler publishes every reply it decodes (its own
read-backs and the poller's polls included) and the cache turns them into state. Three
rules shape it:

* Reads that clear device flags (``""``, ``9`` form I, ``GSS``) are made by the scheduler
  alone; what they report is **latched** here until a client acknowledges it, so no error is
  lost because the poller or another client read it first (§10 "" 注意点, §10 9 ①, §10 GSS).
* ``""`` and ``9`` describe the controller, not a motor; which axis shows a latched error is
  decided in ``latches`` (docs/manual-notes.md, "Latched errors and axes").
* Every change gets the next sequence number and a timestamp (``state_records``) and is
  published on the cache's ``changes`` (an ``EventBus``: callbacks, run as the change is
  made). The cache keeps no history: a reader that needs what it missed takes a
  ``snapshot``; the replay clients resume from is the WebSocket feed's ring
  (``gateway.service.feed``).

Times are whatever the caller stamps events with (the scheduler's clock); nothing here reads
a clock of its own.

Here: what the cache learns from the scheduler's events, and the latches clients acknowledge.
The records, their numbering and staleness are ``state_records``; the record types
``state_types``; what one reply tells ``readings``; the latch rules ``latches``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Mapping
from types import MappingProxyType

from gateway.bus.events import (
    BusEvent,
    ControllerAnswering,
    EventBus,
    FramingChanged,
    LinkDown,
    LinkUp,
    ReplyObserved,
    SelectionChanged,
    TransactionDone,
)
from gateway.bus.latches import latch_errors, unlatch
from gateway.bus.readings import apply_reply
from gateway.bus.state_records import StateRecords
from gateway.bus.state_types import (
    MOTORS,
    AxisState,
    Change,
    ControllerState,
    ErrorKind,
    Latch,
    LoopState,
    Origin,
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
    "Latch",
    "LoopState",
    "Snapshot",
    "StateCache",
]


class StateCache(StateRecords):
    """The latched state of every loop; fed with replies, read by record, snapshot or change."""

    def __init__(self, *, stale_after: float = 3.0) -> None:
        super().__init__(stale_after=stale_after)
        self._counters_published: dict[str, float] = {}
        #: per controller, the errors ``""`` reported since the last ``9`` form I read (the
        #: controller holds them in both stores, §10 9 ③: ``readings``)
        self.status_since_condition: dict[tuple[str, str], frozenset[ErrorKind]] = {}
        self.counters_period = 1.0
        #: the scheduler's events, handed on once the cache has learnt from them (``follow``)
        self._followers: EventBus[BusEvent] = EventBus()

    # ------------------------------------------------------------------ latches

    def latch(
        self, now: float, loop: str, body: str, kinds: Iterable[ErrorKind], source: str
    ) -> None:
        """Latch the errors ``kinds`` a read (the reply to ``source``) reported."""
        ctl = self.flags(loop, body)
        if not kinds and not ctl.latched:
            return  # nothing reported, nothing held: the usual poll
        latched = latch_errors(ctl, kinds, now, source)
        if latched != ctl.latched:
            self.write_controller(now, loop, body, latched=MappingProxyType(latched))

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
            self.write_controller(now, loop, body, latched=MappingProxyType(latched))
        return cleared

    # ------------------------------------------------------------------ the line's events

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
        return self._followers.subscribe(callback)

    def handle(self, event: BusEvent, *, queue_depth: int | None = None) -> None:
        """Take one event of the loop scheduler (subscribe this to its ``EventBus``), then
        hand it to the followers; ``queue_depth``: the scheduler's, if the subscriber knows it."""
        try:
            self._learn(event, queue_depth)
        finally:
            self._followers.publish(event)

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
            if self._stats_due(event.loop, event.time):  # a copy of them only when published
                counters = dataclasses.asdict(event.counters)
                self.set_loop_stats(
                    event.loop, event.time, counters=counters, queue_depth=queue_depth
                )
        elif isinstance(event, FramingChanged):
            self.set_framing(event.loop, event.body, event.framing, event.time)
        elif isinstance(event, ControllerAnswering):
            self.set_online(event.loop, event.body, event.online, event.time)
        elif isinstance(event, SelectionChanged):
            # The scheduler's word: None, in doubt; a motor, read back or executed under ER1.
            confirmed = {"selection_confirmed": event.motor is not None}
            motor = {} if event.motor is None else {"selected_motor": event.motor}
            self.write_controller(event.time, event.loop, event.body, **confirmed, **motor)

    def set_link(self, loop: str, up: bool, now: float, cause: str | None = None) -> None:
        """The loop went up or down. Down: every controller's data is stale; up: nothing is
        restored, the poller reads every controller again. What was read from the line while
        it came back (the scheduler's probes, ``97``: the selection) is current, and kept."""
        self._set_loop(now, loop, up=up, cause=None if up else cause)
        if up:
            self._reconnected(now, loop)
            return
        for name, body in [k for k in self._ctls if k[0] == loop]:
            # Nothing a silent loop said is current: not even that a motor moves (a moving
            # flag that outlived the line would answer requests as a busy controller).
            self.write_controller(
                now,
                name,
                body,
                online=None,
                moving=None,
                selection_confirmed=False,
                signed_positions=None,
            )
            for m in MOTORS:
                self.write_axis(now, name, body, m, stale=True)

    def set_online(self, loop: str, body: str, online: bool, now: float) -> None:
        """The poller found the controller answering (or not): off and back, it has reloaded
        its settings from the EEPROM (§16), EP among them."""
        self.write_controller(now, loop, body, online=online, signed_positions=None)
        if not online:
            # Silent is not switched off: a controller cut from the loop alone may still jog, so
            # whether it moves is unknown, as on a dead loop; a power-on would reset the
            # selection (§16), so it is in doubt too.
            self.write_controller(now, loop, body, moving=None, selection_confirmed=False)
            for m in MOTORS:
                # It may be switched off and on meanwhile: nothing read before counts for a
                # check (the counters will tell whether it was reset, ``gateway.bus.origin``).
                self.write_axis(now, loop, body, m, stale=True, position_current=False)

    def set_framing(self, loop: str, body: str, framing: Framing | None, now: float) -> None:
        """The framing the scheduler uses for the controller (None: not known). It alone
        decides EE/EL/ER/SUM and reads them back from here (``gateway.bus.framing_track``)."""
        self.write_controller(now, loop, body, framing=framing)

    def set_loop_stats(
        self,
        loop: str,
        now: float,
        *,
        counters: Mapping[str, float],
        queue_depth: int | None = None,
    ) -> None:
        """The scheduler's counters (and queue depth); published at most every
        ``counters_period`` seconds so a busy line does not flood the subscribers."""
        if not self._stats_due(loop, now):
            return
        self._counters_published[loop] = now
        depth = {} if queue_depth is None else {"queue_depth": queue_depth}
        self._set_loop(now, loop, counters=MappingProxyType(dict(counters)), **depth)

    def _stats_due(self, loop: str, now: float) -> bool:
        last = self._counters_published.get(loop)
        return last is None or now - last >= self.counters_period

    # ------------------------------------------------------------------ origin
    # A controller reset (power cycle) restarts both counters at 0 wherever the axes stand:
    # the origin is lost until an origin search ends (DESIGN invariant 16,
    # docs/manual-notes.md "How the gateway sees a controller reset").

    def controller_reset(
        self, now: float, loop: str, body: str, cause: str, *, read: int | None = None
    ) -> None:
        """A reset of controller ``body`` was seen (``cause``): both origins are lost, and
        nothing read before ``now`` counts. ``read``: the motor whose reading (0) showed it,
        kept; the other counter is not known until read."""
        # A reset also selects a motor the gateway did not choose (DESIGN invariant 5).
        self.write_controller(
            now, loop, body, reset_at=now, reset_cause=cause, selection_confirmed=False
        )
        for m in MOTORS:
            unread = {} if m == read else {"position": None, "counter": None, "stale": True}
            self.write_axis(
                now,
                loop,
                body,
                m,
                origin=Origin.LOST,
                origin_cause=cause,
                homing=False,
                counting=False,
                position_current=m == read,
                **unread,
            )

    def _reconnected(self, now: float, loop: str) -> None:
        """The line came back: nothing read before counts for a check (the controllers may
        have been reset meanwhile; a reading will tell, ``readings``)."""
        for name, body in [k for k in self._ctls if k[0] == loop]:
            for m in MOTORS:
                self.write_axis(now, name, body, m, position_current=False)
