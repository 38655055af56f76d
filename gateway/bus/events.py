"""What the loop scheduler tells its subscribers, and the in-process publish/subscribe.

Every decoded reply, including the scheduler's own read-backs (``""`` and ``9`` clear the
device's error bits: the state cache latches the errors from these events, DESIGN.md
invariant 4), every unsolicited message, the link going down and up, and every finished
transaction is published. Subscribers are plain callbacks; no threads, no queues.
A callback runs inside the publisher's task: it must not block, and what it raises is logged
and otherwise ignored, so one bad subscriber cannot stop the loop.

``EventBus`` is the gateway's one publish/subscribe primitive: the scheduler's events, the
state cache's changes and the service layer's events all go through one. The one replay is
the WebSocket feed's ring (``gateway.service.feed``).
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, NamedTuple, TypeVar

from gateway.bus.counters import CountersSnapshot
from gateway.bus.requests import Outcome, Priority
from gateway.protocol.framing import Framing
from gateway.protocol.models import Command
from gateway.protocol.replies import ReplyValue
from gateway.protocol.reply_parser import UnsolicitedKind

__all__ = [
    "BusEvent",
    "ControllerAnswering",
    "EventBus",
    "FramingChanged",
    "LinkDown",
    "LinkUp",
    "ReplyObserved",
    "SelectionChanged",
    "TransactionDone",
    "TransactionTally",
    "TransactionsTallied",
    "UnsolicitedMessage",
]

log = logging.getLogger("gateway.bus")


@dataclass(frozen=True, kw_only=True)
class BusEvent:
    """Base of every event: the loop's name and the scheduler clock (monotonic seconds)."""

    loop: str = ""
    time: float = 0.0


@dataclass(frozen=True, kw_only=True)
class ReplyObserved(BusEvent):
    """A reply the scheduler decoded: to a caller's command or to its own (F, read-backs).

    ``value`` is the typed value of a data reply, None for '>' / '>@' (``rejected``). ``motor``
    is the motor the command acted on or read, when the scheduler knows it (the motor suffix,
    or the selection it set); for controller-wide replies (``""``, ``9``) it is the motor that
    was selected then, None if the selection was not known.
    """

    body: str
    command: Command
    value: ReplyValue | None
    motor: int | None = None
    rejected: bool = False
    late: bool = False


@dataclass(frozen=True, kw_only=True)
class UnsolicitedMessage(BusEvent):
    """``$B#*`` (EEPROM write done), ``$B#T`` (timer up) or user-program output (§10, §11-3).

    ``body`` is None for output that does not say which controller sent it ('>text', '@').
    """

    body: str | None
    kind: UnsolicitedKind
    data: str
    raw: bytes = b""


@dataclass(frozen=True, kw_only=True)
class LinkUp(BusEvent):
    """The line is open again: re-read the controllers from the devices, never from cache."""


@dataclass(frozen=True, kw_only=True)
class LinkDown(BusEvent):
    """The line went away; requests fail with ``LoopDown`` until ``LinkUp``."""

    cause: str
    retry_after: float | None = None


@dataclass(frozen=True, kw_only=True)
class TransactionDone(BusEvent):
    """A transaction ended (any outcome); ``counters`` are the loop's totals after it."""

    body: str
    commands: tuple[Command, ...]  # the callers' commands as sent
    motor: int | None = None  # the motor the caller named for the per-motor commands
    outcome: Outcome
    priority: Priority
    duration: float
    exchanges: int
    counters: CountersSnapshot


class TransactionTally(NamedTuple):
    """What the metrics read of one ``TransactionDone``, in plain fields (cheap to carry):
    ``timeouts`` and ``retries`` are what the loop's counters gained with it."""

    body: str
    priority: Priority
    outcome: Outcome
    duration: float
    exchanges: int
    timeouts: int
    retries: int


@dataclass(frozen=True, kw_only=True)
class TransactionsTallied(BusEvent):
    """The transactions that ended over a period and were not published one by one (a line
    worker's idle polls of controllers nobody follows), in the order they ended;
    ``counters`` are the loop's totals after the last of them."""

    tallies: tuple[TransactionTally, ...]
    counters: CountersSnapshot


@dataclass(frozen=True, kw_only=True)
class FramingChanged(BusEvent):
    """The framing the scheduler uses for a controller changed (set by a command or detected);
    None: not known any more (reconnect, power cycle, DL), the loop's initial one is assumed."""

    body: str
    framing: Framing | None
    detected: bool = False  # True: read back from the device after a reply looked wrong


@dataclass(frozen=True, kw_only=True)
class SelectionChanged(BusEvent):
    """The motor the scheduler believes selected (§10 F); None: not known, F is sent again."""

    body: str
    motor: int | None


@dataclass(frozen=True, kw_only=True)
class ControllerAnswering(BusEvent):
    """The poller found a controller silent (``online`` False: its polls went unanswered) or
    answering again after that (True: back, its RAM settings reloaded from EEPROM, §16)."""

    body: str
    online: bool


EventT = TypeVar("EventT")


class EventBus(Generic[EventT]):
    """Publish events to callbacks, in the order they happen.

    Publishing is synchronous: every callback has run when ``publish`` returns. A callback
    that raises is logged and skipped; the publisher and the other callbacks never see it.
    A reader that must not run inside the publisher (a socket, a slow consumer) keeps its own
    bounded buffer and decides there what falling behind means (the feed drops the client).
    The loop scheduler's bus carries ``BusEvent``s; the service layer's ``ServiceEvents`` is
    the same bus for its own events.

    The line first (DESIGN invariant 12): the scheduler calls ``defer`` when a reply is in,
    and from then until its task next yields (its next frame is on the wire by then, or it
    has nothing to send) events reach only the *urgent* subscribers at once: what decides the
    next frame (the state cache's selection and motion, the programs that may print). Every
    other subscriber gets them, in order, right after; before any caller's task wakes up to
    read its result. (The scheduler does not defer after a motion or a stop: see ``exchange``.)
    """

    def __init__(self) -> None:
        self._urgent: list[Callable[[EventT], None]] = []
        self._callbacks: list[Callable[[EventT], None]] = []
        #: events waiting for the non-urgent subscribers (None: deliver at once)
        self._held: list[EventT] | None = None
        #: the subscribers as of the last (un)subscription: a delivery walks this and a
        #: callback that (un)subscribes meanwhile changes the next delivery, not this one;
        #: kept rather than copied at every event (several an exchange)
        self._urgent_now: tuple[Callable[[EventT], None], ...] = ()
        self._callbacks_now: tuple[Callable[[EventT], None], ...] = ()

    def subscribe(
        self, callback: Callable[[EventT], None], *, first: bool = False, urgent: bool = False
    ) -> Callable[[], None]:
        """Call ``callback(event)`` for every event from now on; returns the unsubscriber.

        ``first``: before every other subscriber of its kind, whenever they subscribed (the
        state cache: what a subscriber reads there has always learnt the event it is handed).
        ``urgent``: at once even while delivery is deferred (``defer``), before the others:
        for what the scheduler reads to choose its next frame; it must be quick.
        """
        group = self._urgent if urgent else self._callbacks
        if first:
            group.insert(0, callback)
        else:
            group.append(callback)
        self._changed()

        def unsubscribe() -> None:
            if callback in group:
                group.remove(callback)
                self._changed()

        return unsubscribe

    def _changed(self) -> None:
        self._urgent_now = tuple(self._urgent)
        self._callbacks_now = tuple(self._callbacks)

    def defer(self) -> None:
        """Until the calling task yields, deliver to urgent subscribers only (see the class)."""
        if self._held is None:
            self._held = []
            asyncio.get_running_loop().call_soon(self.release)

    def release(self) -> None:
        """Deliver what ``defer`` held back, in order (events they publish meanwhile too)."""
        held, self._held = self._held, None
        for event in held or ():
            self._deliver(event)

    def publish(self, event: EventT) -> None:
        """Deliver ``event`` to every subscriber now (the urgent ones only, while deferred)."""
        for callback in self._urgent_now:
            try:
                callback(event)
            except Exception:  # one bad subscriber must not stop the loop
                log.exception("event subscriber %r failed on %r", callback, event)
        if self._held is not None:
            self._held.append(event)
        else:
            self._deliver(event)

    def _deliver(self, event: EventT) -> None:
        for callback in self._callbacks_now:
            try:
                callback(event)
            except Exception:  # one bad subscriber must not stop the loop
                log.exception("event subscriber %r failed on %r", callback, event)
