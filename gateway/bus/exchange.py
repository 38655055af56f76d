"""One frame exchanged on a loop (``LineExchange.send``), and the books the line keeps.

``LineExchange.send`` encodes one command model for its controller's framing (a checksum with
SUM1, §10 SUM), lets the ``Link`` exchange it, turns the reply into a ``ReplyKind`` and a typed
value, publishes it (every decoded reply: DESIGN invariant 4), and keeps the books that follow
from it: motor selection (§10 F), framing (§10 EE/EL/ER/SUM, DL), doubt after a lost reply, and
link health (what each frame heard, for ``LineHealth``).

What a doubt makes unknown is forgotten here and only here (``forget``, ``reopened``): the
loop's lifecycle calls it when the port is reopened, the scheduler's ``forget`` after a
controller's power cycle. Who calls whom: a ``TransactionRunner`` (and ``detect``, ``upload``,
``eeprom_hold``) calls ``send``; before each frame ``send`` lets the ``StopLane`` it was handed
send the stops queued meanwhile; the lane runs them through the loop's ``execute``, never
through this class. Nothing here names the scheduler or its lifecycle.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass, replace

from gateway.bus.config import LoopConfig
from gateway.bus.counters import Counters
from gateway.bus.events import (
    BusEvent,
    EventBus,
    FramingChanged,
    ReplyObserved,
    SelectionChanged,
)
from gateway.bus.framing_track import FramingTracker, hint_from_reply
from gateway.bus.line_health import LineHealth
from gateway.bus.link import Link
from gateway.bus.requests import ReplyKind
from gateway.bus.selection import after_accepted, confirm_command, selection_from_reply
from gateway.bus.state import StateCache
from gateway.bus.stop_lane import StopLane
from gateway.bus.timing import Timing, reply_chars
from gateway.errors import ReplyFormatError
from gateway.protocol import commands as cmd
from gateway.protocol.command_replies import decode_for
from gateway.protocol.framing import (
    BODY_NUMBERS,
    Framing,
    Series,
    encode_command,
    framing_switch,
)
from gateway.protocol.models import Command
from gateway.protocol.replies import (
    ReplyValue,
)
from gateway.protocol.reply_parser import (
    Accepted,
    ChecksumMismatch,
    CommandRejected,
    DataReply,
    NotAccepted,
    ReplyEvent,
)
from gateway.protocol.reply_values import ProgramState
from gateway.protocol.spec import Effect, Scope

__all__ = ["DOUBT", "LineExchange", "Sent"]

#: What the scheduler reads to learn whether a controller answers (``LineExchange.probe``).
_PROBE = confirm_command()

#: Kinds after which nobody knows what the controller did or how it is set up.
DOUBT = frozenset({ReplyKind.TIMEOUT, ReplyKind.GARBLED, ReplyKind.CHECKSUM})
#: Frames kept encoded (``LineExchange._send``): the polls of a loop, with room for callers' reads.
_FRAMES_KEPT = 512
#: Replies every subscriber hears at once (``EventBus.defer`` is for the others).
_AT_ONCE = frozenset({Effect.MOTION, Effect.STOP})


@dataclass(frozen=True)
class Sent:
    """One frame's fate."""

    kind: ReplyKind
    value: ReplyValue | None = None
    late: bool = False
    note: str = ""
    frame: bytes = b""  # the bytes written, CR and any checksum included


class LineExchange:
    """One loop's line as its transactions share it: the frame exchange, and what the line
    knows: each controller's selection and framing, the ``$B#*`` heard, its health; and the
    stop lane a stop takes between two frames."""

    def __init__(
        self,
        name: str,
        config: LoopConfig,
        timing: Timing,
        link: Link,
        counters: Counters,
        bus: EventBus[BusEvent],
        clock: Callable[[], float],
        stops: StopLane,
        health: LineHealth,
    ) -> None:
        self.name = name
        self.config = config
        self.timing = timing
        self.link = link
        self.counters = counters
        self.bus = bus
        self.clock = clock
        #: the one home of what the controllers do (the selection among it): fed by the
        #: scheduler's events before any other subscriber (``LoopScheduler.use_state``)
        self.state = StateCache()
        #: the scheduler's rules on the framing; the framing itself is the state cache's
        self.framing = FramingTracker(
            config.initial_framing,
            known=lambda body: self.state.flags(name, body).framing,
            publish=self._framing_changed,
        )
        #: ``$B#*`` seen per controller (a counter, so a waiter cannot miss an early one)
        self.eeprom_done: dict[str, int] = {}
        self.eeprom_event = asyncio.Event()
        #: who answers, who is silent or deaf: one controller silent, or the line gone
        self.health = health
        #: the stops queued meanwhile: sent before any frame of a transaction in flight, and
        #: while an EEPROM write holds the line (the loop's lifecycle runs them)
        self.stops = stops
        #: controllers whose framing read-back failed since the link came up (not retried)
        self.detect_failed: set[str] = set()
        #: frames encoded before, by body, text, series and framing (a pure function of them)
        self._frames: dict[tuple[str, str, Series, Framing], bytes] = {}

    # ------------------------------------------------------------------ doubt

    def forget(self, body: str | None = None) -> None:
        """Forget what a doubt about ``body``'s set-up makes unknown (None: every controller's):
        the motor selected, the framing, a failed framing read-back (power cycle, reopen)."""
        for each in BODY_NUMBERS if body is None else (body,):
            self.set_selection(each, None)
        self.framing.forget(body)
        if body is None:
            self.detect_failed.clear()
        else:
            self.detect_failed.discard(body)

    def reopened(self) -> None:
        """The port was opened again: nothing of any controller's set-up is known, and no
        controller has been silent or deaf on this line yet."""
        self.forget()
        self.health.reopened()

    # ------------------------------------------------------------------ bookkeeping

    def motor_of(self, body: str, command: Command, motor: int | None) -> int | None:
        """The motor ``command`` acts on or reads, as far as the scheduler knows."""
        if command.motor is not None:
            return command.motor
        if command.spec.scope is Scope.PER_MOTOR and motor is not None:
            return motor
        return self.selected(body)

    def selected(self, body: str) -> int | None:
        """The motor selected on ``body`` as far as the scheduler can trust it: the state
        cache's, once confirmed (read back, or ER1's word); None when not known."""
        ctl = self.state.flags(self.name, body)  # no copy of the record for its reply time
        return ctl.selected_motor if ctl.selection_confirmed else None

    def set_selection(self, body: str, motor: int | None) -> None:
        """Publish what the scheduler learnt of the selection (None: not known any more);
        the state cache records it."""
        if motor != self.selected(body):
            self.bus.publish(
                SelectionChanged(loop=self.name, time=self.clock(), body=body, motor=motor)
            )

    def set_framing(self, body: str, framing: Framing, *, detected: bool) -> None:
        """Record a confirmed framing (the state cache keeps it: ``FramingTracker``)."""
        self.framing.set(body, framing, detected=detected)

    def _framing_changed(self, body: str, framing: Framing | None, detected: bool) -> None:
        """Publish the scheduler's word on the framing (None: not known any more)."""
        self.bus.publish(
            FramingChanged(
                loop=self.name, time=self.clock(), body=body, framing=framing, detected=detected
            )
        )

    def doubt(self, body: str) -> None:
        """After a lost, garbled or '?' reply: the selection is not trusted any more."""
        self.set_selection(body, None)

    def publish_reply(
        self,
        body: str,
        command: Command,
        value: ReplyValue | None,
        motor: int | None,
        *,
        rejected: bool = False,
        late: bool = False,
    ) -> None:
        """Publish a decoded reply (callers' commands and the scheduler's own alike)."""
        self.bus.publish(
            ReplyObserved(
                loop=self.name,
                time=self.clock(),
                body=body,
                command=command,
                value=value,
                motor=self.motor_of(body, command, motor),
                rejected=rejected,
                late=late,
            )
        )

    # ------------------------------------------------------------------ one frame

    async def send(self, body: str, command: Command, motor: int | None = None) -> Sent:
        """Send ``command`` once and classify its reply; ``LinkLost`` if the line goes.

        A stop queued meanwhile goes first (DESIGN invariant 8): it is the next frame on the
        wire even in the middle of a transaction.
        """
        if self.stops.waiting():
            await self.stops.send_queued()
        sent = await self._send(body, command, motor)
        self.health.check(body)
        return sent

    async def probe(self, body: str) -> bool:
        """Read ``97`` of ``body`` (clears nothing, allowed while a motor moves, §10 9): True
        when any byte came back. Never takes the line down (``LinkLost`` only if the port goes)."""
        heard = self.link.heard_any
        self.link.heard_any = False
        await self._send(body, _PROBE, None)
        answered = self.link.heard_any
        self.link.heard_any = heard or answered
        return answered

    async def _send(self, body: str, command: Command, motor: int | None) -> Sent:
        framing = self.framing.get(body)
        series = self.config.series_of(body)
        text = command.wire()
        switch = framing_switch(framing, text) if command.form.switches_framing else None
        reply_framing = switch.reply if switch is not None else framing
        key = (body, text, series, framing)
        frame = self._frames.get(key)
        if frame is None:  # the poller asks the same few frames again and again
            frame = encode_command(body, text, series=series, framing=framing)
            if len(self._frames) >= _FRAMES_KEPT:
                self._frames.clear()
            self._frames[key] = frame
        ran = self.link.programs.may_run(body)  # before this frame and its reply
        self.link.programs.sending(body, command)  # a program may print before G's '>' ends
        exchange = await self.link.exchange(
            body,
            frame,
            has_data=command.reply_format.has_data,
            framing=reply_framing,
            series=series,
            reply_len=reply_chars(command, reply_framing, len(frame)),
        )
        # The reply is in: until the next frame is written, only what chooses it hears of it.
        # Not after a motion or a stop: a subscriber may withdraw what must not follow it
        # (the poller's reads that are refused while a motor moves, 動作中 ×).
        if command.form.effect not in _AT_ONCE:
            self.bus.defer()
        self.counters.exchanges += 1
        sent = self._classify(body, command, exchange.event, reply_framing, motor, exchange.late)
        if exchange.event is not None and _misfit(command, sent):
            # It may be another command's reply, come late: the line is out of step until it
            # has been quiet long enough (``Link.resync``, before the next frame).
            self.link.step_out(late=sent.late)
        self._after(body, command, sent, framing, motor)
        if _program_news(command, sent, ran=ran):
            # A program started, ended or was seen running or ended: it may have selected
            # another motor with no frame of the gateway's (§10 G, F in programs).
            self.doubt(body)
        if exchange.heard:
            self.health.heard(body)
        elif sent.kind is ReplyKind.TIMEOUT:
            self.health.timed_out(body)
        return replace(sent, frame=frame)

    def _classify(
        self,
        body: str,
        command: Command,
        event: ReplyEvent | None,
        framing: Framing,
        motor: int | None,
        late: bool,
    ) -> Sent:
        printing = self.link.programs.printing
        if event is not None and (
            hint := hint_from_reply(event, command, framing, printing=printing)
        ):
            self.framing.suspect(body, hint)
        if event is None:
            return Sent(ReplyKind.TIMEOUT, note="no reply in time")
        if isinstance(event, NotAccepted):
            self.counters.naks += 1
            return Sent(ReplyKind.NOT_ACCEPTED, late=late, note="'?': not taken")
        if isinstance(event, CommandRejected):
            self.publish_reply(body, command, None, motor, rejected=True, late=late)
            return Sent(ReplyKind.REJECTED, late=late, note="'>@': command error (ER1)")
        if isinstance(event, Accepted):
            self.publish_reply(body, command, None, motor, late=late)
            note = "a query answered with a bare '>'" if command.reply_format.has_data else ""
            return Sent(ReplyKind.ACCEPTED, late=late, note=note)
        if isinstance(event, DataReply):
            try:
                value = decode_for(command, event.data)
            except (ReplyFormatError, ValueError) as exc:
                self.counters.garbled += 1
                return Sent(ReplyKind.GARBLED, late=late, note=f"reply does not decode: {exc}")
            shown = selection_from_reply(command, value)
            if shown is not None:  # '9', '97', 'F' show the selection: published with it
                self.set_selection(body, shown)
            self.publish_reply(body, command, value, motor, late=late)
            return Sent(ReplyKind.DATA, value, late=late)
        if isinstance(event, ChecksumMismatch):
            self.counters.checksum_errors += 1
            return Sent(ReplyKind.CHECKSUM, late=late, note=f"checksum mismatch: {event.raw!r}")
        self.counters.garbled += 1
        return Sent(ReplyKind.GARBLED, late=late, note=f"garbled: {event.raw!r}")

    def _after(
        self, body: str, command: Command, sent: Sent, framing: Framing, motor: int | None
    ) -> None:
        """Selection and framing books after one frame."""
        if sent.kind in DOUBT or sent.kind is ReplyKind.NOT_ACCEPTED:
            self.doubt(body)
            if command.form.switches_framing and sent.kind in DOUBT:
                self.framing.suspect(body, f"the reply to {command.wire()} was lost")
            return
        if sent.kind is not ReplyKind.ACCEPTED or command.reply_format.has_data:
            return
        if command.form.switches_framing:
            switch = framing_switch(framing, command.wire())
            if not switch.refused:
                self.set_framing(body, switch.after, detected=False)
        elif command.form is cmd.LOAD_SETTINGS:
            # §10 DL loads the framing stored by DW: not known any more.
            self.framing.forget(body)
            self.framing.suspect(body, "DL loaded the framing from EEPROM")
        elif command.form.selects_motor and command.form is not cmd.SELECT_MOTOR:
            changed = after_accepted(command, framing)
            if changed is not False:
                self.set_selection(body, changed if isinstance(changed, int) else None)

    # ------------------------------------------------------------------ EEPROM

    def note_eeprom_done(self, body: str) -> None:
        """A ``$B#*`` from ``body`` (§10 AW, DW, IW, EE///)."""
        self.eeprom_done[body] = self.eeprom_done.get(body, 0) + 1
        self.health.deaf(body, None)
        self.eeprom_event.set()
        self.eeprom_event = asyncio.Event()


def _misfit(command: Command, sent: Sent) -> bool:
    """A reply that does not fit the form its command expects: a line error, never a value
    (DESIGN invariant 13). A garbled or bad-checksum message, or a bare '>' to a query."""
    if sent.kind in (ReplyKind.GARBLED, ReplyKind.CHECKSUM):
        return True
    return sent.kind is ReplyKind.ACCEPTED and command.reply_format.has_data


def _program_news(command: Command, sent: Sent, *, ran: bool) -> bool:
    """Whether ``sent`` tells that a user program started, ended, or runs (or may have);
    ``ran``: one may have run before this frame. A ``GSS`` of 0 where none was seen running
    tells nothing (the poller reads it every condition period)."""
    form = command.form
    if form in cmd.PROGRAM_STARTS or form in cmd.PROGRAM_ENDS:
        return True
    if not isinstance(sent.value, ProgramState):
        return False
    return ran or sent.value is not ProgramState.ENDED
