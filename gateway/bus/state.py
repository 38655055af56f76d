"""The gateway's latched picture of every loop, controller and axis (DESIGN invariants 4, 9).

The cache only listens: the loop scheduler publishes every reply it decodes (its own
read-backs and the poller's polls included) and the cache turns them into state. Three
rules shape it:

* Reads that clear device flags (``""``, ``9`` form I, ``GSS``) are made by the scheduler
  alone; what they report is **latched** here until a client acknowledges it, so no error is
  lost because the poller or another client read it first (§10 "" 注意点, §10 9 ①, §10 GSS).
* ``""`` and ``9`` describe the controller, not a motor; which axis shows a latched error is
  decided by ``_attribute`` (docs/manual-notes.md, "Latched errors and axes").
* Every change gets the next sequence number and a timestamp, is kept in a bounded history
  and is published to subscribers; a subscriber that fell behind asks for the changes since
  its last number, or takes a fresh snapshot when the history no longer reaches back.

Times are whatever the caller stamps events with (the scheduler's clock); nothing here reads
a clock of its own.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
from collections import deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from enum import StrEnum
from types import MappingProxyType
from typing import Any

from gateway.bus.events import (
    BusEvent,
    FramingChanged,
    LinkDown,
    LinkUp,
    ReplyObserved,
    SelectionChanged,
    TransactionDone,
)
from gateway.protocol.framing import POWER_ON, Framing
from gateway.protocol.models import Command
from gateway.protocol.replies import ReplyValue
from gateway.protocol.reply_values import (
    ConditionFlags,
    ProgramState,
    SensorBits,
    StatusFlags,
    Version,
)
from gateway.protocol.spec import Effect

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

MOTORS = (1, 2)


class ErrorKind(StrEnum):
    """An error a read reports once and clears on the device (§10 "", §10 9, §10 GSS)."""

    LIMIT = "limit_error"  # "" bit 1, 9 bit 1
    EMERGENCY = "emergency_stop"  # "" bit 2, 9 bit 2
    COMMAND = "command_error"  # "" bit 3, 9 bit 3
    COMMUNICATION = "communication_error"  # 9 bit 0 only: noise or receive overflow
    PROGRAM = "program_error"  # GSS 'E': a user program ended by a command error


#: Errors shown on the axes as well as on the controller.
AXIS_ERRORS = (ErrorKind.LIMIT, ErrorKind.EMERGENCY, ErrorKind.COMMAND)
_STATUS_KINDS = {"limit_error": ErrorKind.LIMIT, "emergency_stop": ErrorKind.EMERGENCY}
_STATUS_KINDS["command_error"] = ErrorKind.COMMAND


@dataclass(frozen=True)
class Latch:
    """One latched error of a controller, held until acknowledged."""

    kind: ErrorKind
    #: the motors whose axis still shows it (empty for controller-only kinds)
    axes: frozenset[int]
    first: float  # when a read first reported it
    last: float  # when a read last reported it
    count: int  # how many reads reported it since it was latched
    source: str  # the command (form key) whose reply reported it last, e.g. '""'


@dataclass(frozen=True)
class AxisState:
    """One motor of one controller as the gateway last saw it."""

    motor: int
    position: int | None = None  # as the controller reports it (EP0 unsigned, EP1 signed)
    moving: bool = False
    sensors: SensorBits | None = None
    selected: bool = False  # F selects this motor (§10 F)
    step_out: bool = False  # 9 bit 6: held by the device until homing or RD (§10 9 ⑤)
    limit_error: bool = False  # latched, until acknowledged
    emergency: bool = False  # latched
    command_error: bool = False  # latched
    updated: float | None = None  # last fresh status or position
    stale: bool = True  # no fresh data for ``StateCache.stale_after`` seconds


@dataclass(frozen=True)
class ControllerState:
    """One controller: identity, framing, raw flags, latched errors and its two axes."""

    body: str
    online: bool | None = None  # None: not probed yet
    version: Version | None = None
    mode: int | None = None  # E (§10 E), also 9 bits 5,4
    framing: Framing | None = None
    status: StatusFlags | None = None  # the last "" reply as read
    condition: ConditionFlags | None = None  # the last 9 (form I) reply as read
    condition_bits: Mapping[int, int] = field(default_factory=lambda: MappingProxyType({}))
    program: ProgramState | None = None
    moving: bool = False  # "" bit 0
    selected_motor: int | None = None
    #: False while the selection is only inferred from a '>' (which does not mean the command
    #: was valid, §9-2); True once read back with 9, 97 or F
    selection_confirmed: bool = False
    last_moved: int | None = None  # the motor of the latest move the gateway knows of
    latched: Mapping[ErrorKind, Latch] = field(default_factory=lambda: MappingProxyType({}))
    updated: float | None = None


@dataclass(frozen=True)
class LoopState:
    """One serial loop: link state, queue depth and the scheduler's counters."""

    name: str
    up: bool = False
    cause: str | None = None  # why it went down
    queue_depth: int = 0
    counters: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    updated: float | None = None


@dataclass(frozen=True)
class Change:
    """What changed in one loop, controller or axis: the new values of the fields that moved."""

    seq: int
    time: float
    loop: str
    body: str | None  # None: the loop itself
    motor: int | None  # None: the controller (or the loop)
    values: Mapping[str, Any]


@dataclass(frozen=True)
class Snapshot:
    """Everything at once, as of change ``seq``."""

    seq: int
    loops: Mapping[str, LoopState]
    controllers: Mapping[tuple[str, str], ControllerState]
    axes: Mapping[tuple[str, str, int], AxisState]


class FellBehind(Exception):
    """A subscription dropped changes because its queue was full; call ``resync``."""


class Subscription:
    """The changes of a ``StateCache`` as an asyncio queue (``async for change in sub``).

    A reader that is too slow does not slow the gateway: once the queue is full further
    changes are dropped, and after the queued ones ``get`` raises ``FellBehind``; ``resync``
    then returns what was missed (the changes, or a snapshot when the history no longer
    reaches back) and delivery goes on from there.
    """

    def __init__(self, cache: StateCache, maxsize: int) -> None:
        self._cache = cache
        self._queue: asyncio.Queue[Change] = asyncio.Queue(maxsize)
        self.last_seq = cache.seq  # the last change delivered (or caught up with)
        self.behind = False

    def _put(self, change: Change) -> None:
        if self.behind:
            return
        try:
            self._queue.put_nowait(change)
        except asyncio.QueueFull:
            self.behind = True

    async def get(self) -> Change:
        """The next change; ``FellBehind`` once the queue overflowed and is drained."""
        if self.behind and self._queue.empty():
            raise FellBehind(f"changes after {self.last_seq} were dropped")
        change = await self._queue.get()
        self.last_seq = change.seq
        return change

    def resync(self) -> list[Change] | Snapshot:
        """What was missed since ``last_seq``; delivery resumes after it."""
        missed: list[Change] | Snapshot | None = self._cache.changes_since(self.last_seq)
        if missed is None:
            missed = self._cache.snapshot()
        while not self._queue.empty():
            self._queue.get_nowait()
        self.behind = False
        self.last_seq = self._cache.seq
        return missed

    def close(self) -> None:
        """Stop receiving changes."""
        self._cache._subscriptions.discard(self)

    def __aiter__(self) -> Subscription:
        return self

    async def __anext__(self) -> Change:
        return await self.get()


class StateCache:
    """The latched state of every loop; fed with replies, read by snapshot, change or stream."""

    def __init__(self, *, history: int = 10_000, stale_after: float = 3.0) -> None:
        self.stale_after = stale_after
        self._seq = 0
        self._history: deque[Change] = deque(maxlen=history)
        self._loops: dict[str, LoopState] = {}
        self._ctls: dict[tuple[str, str], ControllerState] = {}
        self._axes: dict[tuple[str, str, int], AxisState] = {}
        self._subscriptions: set[Subscription] = set()
        self._callbacks: list[Callable[[Change], None]] = []
        self._counters_published: dict[str, float] = {}
        self.counters_period = 1.0

    # ------------------------------------------------------------------ reading

    @property
    def seq(self) -> int:
        """The number of the latest change (0: none yet)."""
        return self._seq

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

    def changes_since(self, seq: int) -> list[Change] | None:
        """The changes after ``seq``; None when the history no longer reaches back (resync
        with ``snapshot``)."""
        if seq >= self._seq:
            return []
        oldest = self._history[0].seq if self._history else self._seq + 1
        if seq + 1 < oldest:
            return None
        return [c for c in self._history if c.seq > seq]

    def subscribe(self, maxsize: int = 1000) -> Subscription:
        """A queue of every change from now on (see ``Subscription`` for falling behind)."""
        sub = Subscription(self, maxsize)
        self._subscriptions.add(sub)
        return sub

    def listen(self, callback: Callable[[Change], None]) -> Callable[[], None]:
        """Call ``callback`` with every change (synchronously); returns the unsubscribe."""
        self._callbacks.append(callback)
        return lambda: self._callbacks.remove(callback) if callback in self._callbacks else None

    # ------------------------------------------------------------------ writing

    def _emit(self, now: float, loop: str, body: str | None, motor: int | None, **v: Any) -> None:
        self._seq += 1
        change = Change(self._seq, now, loop, body, motor, MappingProxyType(v))
        self._history.append(change)
        for sub in list(self._subscriptions):
            sub._put(change)
        for callback in list(self._callbacks):
            try:
                callback(change)
            except Exception:  # one bad listener must not stop the others
                log.exception("state listener %r failed", callback)

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
            step_out = bool(ctl.condition_bits.get(6)) and _attribute(ctl) in (None, m)
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
        latched = dict(ctl.latched)
        for kind in kinds:
            axes = _axes_for(kind, ctl)
            old = latched.get(kind)
            if old is None:
                latched[kind] = Latch(kind, axes, now, now, 1, source)
            else:
                latched[kind] = replace(
                    old, axes=old.axes | axes, last=now, count=old.count + 1, source=source
                )
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
        wanted = set(ErrorKind) if kinds is None else set(kinds)
        latched = dict(ctl.latched)
        cleared: list[ErrorKind] = []
        for kind in [k for k in latched if k in wanted]:
            if motor is None:
                cleared.append(kind)
                del latched[kind]
            elif motor in latched[kind].axes:
                left = latched[kind].axes - {motor}
                if left:
                    latched[kind] = replace(latched[kind], axes=left)
                else:
                    cleared.append(kind)
                    del latched[kind]
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
        _Reading(self, loop, body, command, time, motor).apply(value, rejected)

    def handle(self, event: BusEvent, *, queue_depth: int | None = None) -> None:
        """Take one event of the loop scheduler (subscribe this to its ``EventBus``);
        ``queue_depth``: the scheduler's, if the subscriber knows it."""
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
        elif isinstance(event, SelectionChanged) and event.motor is None:
            self._set_ctl(event.time, event.loop, event.body, selection_confirmed=False)

    def set_link(self, loop: str, up: bool, now: float, cause: str | None = None) -> None:
        """The loop went up or down. Down: every controller's data is stale; up: nothing is
        restored, the poller reads every controller again (issue 4)."""
        self._set_loop(now, loop, up=up, cause=None if up else cause)
        for name, body in [k for k in self._ctls if k[0] == loop]:
            self._set_ctl(now, name, body, online=None, selection_confirmed=False)
            for m in MOTORS:
                self._set_axis(now, name, body, m, stale=True)

    def set_online(self, loop: str, body: str, online: bool, now: float) -> None:
        """The poller found the controller answering (or not)."""
        self._set_ctl(now, loop, body, online=online)
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


def _attribute(ctl: ControllerState) -> int | None:
    """The motor a controller-wide limit or step-out error belongs to; None = unknown.

    While a motor moves it is the selected one (F cannot change during a move, §10 F); after
    a move the one that moved last; else the selected motor.
    """
    if ctl.moving and ctl.selected_motor is not None:
        return ctl.selected_motor
    return ctl.last_moved or ctl.selected_motor


def _axes_for(kind: ErrorKind, ctl: ControllerState) -> frozenset[int]:
    if kind is ErrorKind.LIMIT:
        motor = _attribute(ctl)
        return frozenset(MOTORS) if motor is None else frozenset({motor})
    if kind in AXIS_ERRORS:  # EMS is common to both motors (§10 EA); a command error names none
        return frozenset(MOTORS)
    return frozenset()


class _Reading:
    """What one reply tells: dispatch on the command's reply format and form."""

    def __init__(
        self,
        cache: StateCache,
        loop: str,
        body: str,
        command: Command,
        now: float,
        hint: int | None,
    ) -> None:
        self.cache, self.loop, self.body, self.command, self.now = cache, loop, body, command, now
        self.hint = hint  # the scheduler's motor for a command without a suffix

    def motor(self, ctl: ControllerState) -> int | None:
        """The motor the command acted on: its suffix, else the selection (§10 F)."""
        return self.command.motor or self.hint or ctl.selected_motor

    def ctl(self, **values: Any) -> None:
        self.cache._set_ctl(self.now, self.loop, self.body, **values)

    def axis(self, motor: int, **values: Any) -> None:
        self.cache._set_axis(self.now, self.loop, self.body, motor, **values)

    def latch(self, kinds: Iterable[ErrorKind]) -> None:
        self.cache._latch(self.now, self.loop, self.body, kinds, self.command.key)

    def apply(self, value: ReplyValue | None, rejected: bool) -> None:
        ctl = self.cache.controller(self.loop, self.body)
        self.ctl(online=True, updated=self.now)
        if value is None and not rejected:  # '>' (a '>@' changed nothing, §10 ER)
            self.accepted(ctl)
        elif isinstance(value, StatusFlags):
            self.status(ctl, value)
        elif isinstance(value, ConditionFlags):
            self.condition(ctl, value)
        elif isinstance(value, ProgramState):
            self.ctl(program=value)
            if value is ProgramState.ERROR:  # GSS: reading E clears it to 0 (§10 GSS)
                self.latch([ErrorKind.PROGRAM])
        elif isinstance(value, Version):
            self.ctl(version=value)
        elif isinstance(value, SensorBits):
            motor = self.motor(ctl)  # CL: the selected (or moving) motor
            if motor is not None:
                self.axis(motor, sensors=value)
        elif isinstance(value, int) and not isinstance(value, bool):
            self.number(ctl, value)

    def accepted(self, ctl: ControllerState) -> None:
        form, key = self.command.form, self.command.key
        if key.startswith("F{") and not ctl.moving:  # F cannot be used while moving (§10 F)
            self.ctl(selected_motor=self.command.motor, selection_confirmed=False)
        elif form.effect is Effect.MOTION and not ctl.moving:
            # A suffix selects the motor and the selection stays (§9-1, §10 F).
            moved = self.motor(ctl)
            self.ctl(selected_motor=moved, last_moved=moved, selection_confirmed=False)
        elif key[:-1] in ("EE", "EL", "ER", "SUM") and key[-1:] in "01":
            self.framing(key[:-1], key[-1] == "1")

    def framing(self, switch: str, on: bool) -> None:
        names = {"EE": "echo", "EL": "cr_after_ack", "ER": "error_mark", "SUM": "checksum"}
        current = self.cache.controller(self.loop, self.body).framing or POWER_ON
        with contextlib.suppress(ValueError):  # EE1 with SUM1: refused (§10 EE, SUM)
            self.ctl(framing=replace(current, **{names[switch]: on}))

    def status(self, ctl: ControllerState, flags: StatusFlags) -> None:
        # "" clears bits 1-3 after the reply (§10 "" 注意点): latch them now or lose them.
        if flags.moving and not ctl.moving and ctl.selected_motor is not None:
            self.ctl(last_moved=ctl.selected_motor)
        self.ctl(status=flags, moving=flags.moving)
        self.latch(k for name, k in _STATUS_KINDS.items() if getattr(flags, name))
        for m in MOTORS:
            self.axis(m, updated=self.now, stale=False)

    def condition(self, ctl: ControllerState, flags: ConditionFlags) -> None:
        # 9 form I clears bits 0-3 after the reply (§10 9 ①); bit 6 stays (§10 9 ⑤).
        bits = dict(ctl.condition_bits)
        bits.update({0: 0, 1: 0, 2: 0, 3: 0, 6: int(flags.step_out)})
        bits.update({4: flags.mode, 5: flags.mode, 7: flags.selected_motor - 1})
        self.ctl(
            condition=flags,
            mode=flags.mode,
            selected_motor=flags.selected_motor,
            selection_confirmed=True,
            condition_bits=MappingProxyType(bits),
        )
        kinds = [k for name, k in _STATUS_KINDS.items() if getattr(flags, name)]
        self.latch([ErrorKind.COMMUNICATION] * flags.communication_error + kinds)

    def number(self, ctl: ControllerState, value: int) -> None:
        key = self.command.key
        if key in ("6", "6{mt}"):
            motor = self.motor(ctl)
            if motor is not None:
                self.axis(motor, position=value, updated=self.now, stale=False)
        elif key == "9{bit}":
            self.condition_bit(ctl, int(self.command.params()["bit"]), value)
        elif key == "E":
            self.ctl(mode=value)
        elif key == "F":
            self.ctl(selected_motor=value, selection_confirmed=True)
        elif key in ("EE", "EL", "ER", "SUM"):
            self.framing(key, value == 1)

    def condition_bit(self, ctl: ControllerState, bit: int, value: int) -> None:
        # 9{bit} clears nothing (§10 9 ②): the device holds a set bit until a 9 form I read,
        # so only a 0 -> 1 change is a new communication error. Bits 1-3 repeat what the
        # status flags (polled with "") report, in their own store: not latched again.
        was = ctl.condition_bits.get(bit)
        self.ctl(condition_bits=MappingProxyType({**ctl.condition_bits, bit: value}))
        if bit == 0 and value and was != 1:
            self.latch([ErrorKind.COMMUNICATION])
        elif bit in (4, 5):
            self.ctl(mode=value)
        elif bit == 7:
            self.ctl(selected_motor=value + 1, selection_confirmed=True)
