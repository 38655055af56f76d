"""The receiving side of one loop's port: the reply parser fed as bytes come, the routing.

The port is read all the time, so unsolicited messages (``$B#*``, ``$B#T``, program
output, §10 AW/DW/IW/EE///, §10 T, §11-3) are recognised between and around replies; the
parser (``gateway.protocol.reply_parser``) never lets them satisfy a pending reply. Each event
goes to the exchange awaiting a reply (when it is that reply), to the scheduler (unsolicited
messages), or is counted: late (after a time-out), garbled, or stray (framing hints). A
program's output goes to the scheduler even while a late reply is awaited (``printed``, while
a program may print): no printed line is lost for a reply that did not come.
A message left half-received is ended when the line has been quiet for a few characters.

The transport hands each chunk over from its ``data_received`` (``Transport.deliver``): the
parser runs there and the exchange awaiting the reply is woken from there, with no reader task
woken per chunk in between. A transport that cannot (a test's own) is read by a reader task.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable

from gateway.bus.counters import Counters
from gateway.bus.lateness import Lateness
from gateway.bus.programs_seen import ProgramsSeen
from gateway.bus.timing import Timing
from gateway.bus.trace import FrameDirection, LineTrace
from gateway.protocol.reply_parser import (
    ChecksumMismatch,
    Garbled,
    ReplyEvent,
    ReplyParser,
    Unsolicited,
    UnsolicitedKind,
)
from gateway.transport.base import Sink, Transport, TransportClosed

__all__ = ["ALWAYS_MEANT", "LinkLost", "Pending", "Receiver", "printed"]

#: '$B#*' / '$B#T' are never a reply, whenever they come (parser notes).
ALWAYS_MEANT = (UnsolicitedKind.EEPROM_DONE, UnsolicitedKind.TIMER_UP)


def printed(event: ReplyEvent) -> bool:
    """Whether ``event`` is a user program's output that cannot be a late reply: ``/CO``
    (``>text`` CR), query output without '>' (``$B#data`` CR, §11-3) or '@' (§10 ER). A
    ``>$B#data`` CR (``/CC``, ``/O3``) is shaped like a query reply and may be one."""
    if not isinstance(event, Unsolicited) or event.kind is not UnsolicitedKind.PROGRAM_OUTPUT:
        return False
    return not (event.raw[:1] == b">" and event.raw[1:2] in (b"$", b"#"))


class LinkLost(Exception):
    """The port went away (or the link was stopped) during an exchange."""

    def __init__(self, cause: str) -> None:
        super().__init__(cause)
        self.cause = cause


class Pending:
    """The exchange awaiting its reply.

    ``future`` holds the reply (or ``LinkLost``); ``wake`` is what the exchange awaits now: it
    is woken by the reply or by its time-out, so the scheduler resumes one hop after the
    reply's last byte (``asyncio.wait`` would take two, letting other work in between).
    """

    def __init__(self, body: str, future: asyncio.Future[ReplyEvent]) -> None:
        self.body = body
        self.future = future
        self.late_phase = False
        self.heard = False
        self.wake: asyncio.Future[None] | None = None

    def resolve(self, event: ReplyEvent) -> None:
        """The reply came: keep it and wake the exchange."""
        self.future.set_result(event)
        self.rouse()

    def fail(self, error: Exception) -> None:
        """The line went: the exchange raises ``error``."""
        self.future.set_exception(error)
        self.rouse()

    def rouse(self) -> None:
        """Wake the exchange (its reply came, the line went, or its time is up)."""
        wake = self.wake
        if wake is not None and not wake.done():
            wake.set_result(None)

    async def wait(self, timeout: float) -> None:
        """Until the reply (or the loss of the line) or ``timeout`` real seconds."""
        if self.future.done():
            return
        event_loop = asyncio.get_running_loop()
        self.wake = wake = event_loop.create_future()
        timer = event_loop.call_later(timeout, self.rouse)
        try:
            await wake
        finally:
            timer.cancel()
            self.wake = None


class Receiver(Sink):
    """The port of one loop as far as reading goes: what it receives, parser, routing."""

    def __init__(
        self,
        transport: Transport,
        timing: Timing,
        counters: Counters,
        trace: LineTrace,
        *,
        on_unsolicited: Callable[[Unsolicited], None],
        on_stray: Callable[[ReplyEvent, str | None], None],
        on_lost: Callable[[], None],
        clock: Callable[[], float],
        programs: ProgramsSeen | None = None,
    ) -> None:
        self.transport = transport
        #: which controllers may have a program printing (the parser's ``printing``)
        self.programs = programs or ProgramsSeen()
        self.timing = timing
        self._counters = counters
        self._trace = trace
        self._on_unsolicited = on_unsolicited
        self._on_stray = on_stray
        self._on_lost = on_lost
        self._clock = clock
        self.parser = ReplyParser()
        self._pending: Pending | None = None
        self._reader: asyncio.Task[None] | None = None
        #: the transport hands chunks over itself (``received``): no reader task
        self._delivered = False
        self._quiet_handle: asyncio.TimerHandle | None = None
        self._idle = asyncio.Event()  # no message half-received
        self._idle.set()
        #: the controller that answered last (strays after a reply are attributed to it)
        self.last_body: str | None = None
        self._rx_chunks = 0  # chunks received so far (a quiet period sees it unchanged)
        self._probe: bytearray | None = None  # a framing probe collects raw bytes
        self._probe_changed = asyncio.Event()
        self.lost_cause: str | None = None
        self.lost = asyncio.Event()
        #: time-outs in a row with no byte received at all (link health)
        self.silent_timeouts = 0
        #: any byte received since ``start`` (a reconnect that works resets the backoff)
        self.heard_any = False
        self._last_frame = b""  # the last frame written, to recognise its echo (EE1)
        #: a reply may still come that no exchange awaits (a time-out, a reply that did not
        #: fit its command, bytes after a reply): no reply is trusted until ``Link.resync``
        self.out_of_step = False
        #: a resync is waiting for silence: whatever arrives is late and dropped
        self.resyncing = False
        #: how late this line's replies come (the resync's silence grows with it)
        self.lateness = Lateness()
        #: resyncs made (after time-outs included) and the host seconds they held the line
        self.resyncs = 0
        self.resync_time = 0.0

    # ------------------------------------------------------------------ lifetime

    def start(self) -> None:
        """Start reading (the transport is open)."""
        self.lost_cause = None
        self.lost.clear()
        self.silent_timeouts = 0
        self.heard_any = False
        self.out_of_step = False  # a new connection: nothing is on its way on it yet
        self.parser = ReplyParser()
        self._idle.set()
        try:
            self._delivered = self.transport.deliver(self)
        except TransportClosed:  # gone already: a reader task meets it and says why
            self._delivered = False
        if not self._delivered:
            event_loop = asyncio.get_running_loop()
            self._reader = event_loop.create_task(self._read_loop(), name="bus-reader")

    async def stop(self) -> None:
        """Stop reading; a pending exchange fails with ``LinkLost``."""
        self.lose("stopped")
        if self._delivered:
            self._delivered = False
            with contextlib.suppress(TransportClosed):
                self.transport.deliver(None)  # what still comes waits for the next start
        if self._reader is not None:
            self._reader.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await self._reader
            self._reader = None

    def lose(self, cause: str) -> None:
        """The line is gone: fail the pending exchange; the scheduler reconnects."""
        if self.lost_cause is None:
            self.lost_cause = cause
            self.lost.set()
            self._on_lost()
        if self._quiet_handle is not None:
            self._quiet_handle.cancel()
            self._quiet_handle = None
        self._idle.set()
        pending = self._pending
        if pending is not None and not pending.future.done():
            pending.fail(LinkLost(self.lost_cause))

    # ------------------------------------------------------------------ receiving

    def received(self, data: bytes) -> None:
        """A chunk from the transport's ``data_received`` (``Sink``)."""
        if not self._delivered:
            return  # stopped: nobody reads this connection any more
        try:
            self._received(data)
        except Exception as exc:  # as a reader task's end: the line is gone, read no more
            self._delivered = False
            self.lose(f"read failed: {exc!r}")

    def closed(self, error: TransportClosed) -> None:
        """The connection is gone (``Sink``)."""
        self._delivered = False
        self.lose(f"transport closed: {error}")

    async def _read_loop(self) -> None:
        try:
            while True:
                data = await self.transport.read()
                if data:
                    self._received(data)
        except TransportClosed as exc:
            self.lose(f"transport closed: {exc}")
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # the serial library's own errors: the line is gone
            self.lose(f"read failed: {exc!r}")

    def _received(self, data: bytes) -> None:
        self._rx_chunks += 1
        counters = self._counters
        counters.bytes_in += len(data)
        counters.busy_time += self.timing.wire(len(data))
        self.silent_timeouts = 0
        self.heard_any = True
        pending = self._pending
        if pending is not None:
            pending.heard = True
        body = pending.body if pending is not None else None
        if self._trace.on:
            self._trace.add(self._clock(), FrameDirection.RX, body, data)
        if self._probe is not None:
            self._probe += data  # the framing is in doubt: read raw, not with the parser
            self._probe_changed.set()
            return
        events = self.parser.feed(data)
        for event in events:
            self._route(event)
        if self.parser.at_rest:
            # Every message ended (the usual reply in one chunk): the end of the line's quiet
            # would find nothing to end, so no timer is armed for it (one less a reply).
            if self._quiet_handle is not None:
                self._quiet_handle.cancel()
                self._quiet_handle = None
            self._idle.set()
            return
        # A chunk that did not end with a complete message leaves one half-received.
        if events and data.endswith(events[-1].raw):
            self._idle.set()
        else:
            self._idle.clear()
        self._arm_quiet()

    def _arm_quiet(self) -> None:
        if self._quiet_handle is not None:
            self._quiet_handle.cancel()
        event_loop = asyncio.get_running_loop()
        self._quiet_handle = event_loop.call_later(self.timing.quiet(), self._line_quiet)

    def _line_quiet(self) -> None:
        self._quiet_handle = None
        for event in self.parser.line_quiet():
            self._route(event)
        self._idle.set()

    def step_out(self, *, late: bool) -> None:
        """The line is out of step (``Link.resync`` before the next frame); ``late``: a reply
        came now that belongs to an earlier exchange (its lateness is learnt)."""
        self.out_of_step = True
        if late:
            self.lateness.arrived(asyncio.get_running_loop().time())

    def _printed(self, event: ReplyEvent) -> bool:
        """A program's line, while a program may print: never taken for a late reply."""
        return self.programs.printing and printed(event)

    def _route(self, event: ReplyEvent) -> None:
        pending = self._pending
        if event.is_reply and pending is not None and not pending.future.done():
            self.last_body = pending.body
            pending.resolve(event)
            return
        if isinstance(event, Unsolicited) and event.kind in ALWAYS_MEANT:
            self._on_unsolicited(event)  # '$B#*' / '$B#T' are never a reply (parser notes)
            return
        late = pending is not None and pending.late_phase
        if (late or self.resyncing) and not self._printed(event):
            self.lateness.arrived(asyncio.get_running_loop().time())
            self._counters.late_replies += 1
            where = pending.body if pending is not None else self.last_body
            self._trace.add(self._clock(), FrameDirection.NOTE, where, event.raw, "late")
            return
        if isinstance(event, Unsolicited):
            if not self.programs.printing and not printed(event):
                self.step_out(late=True)  # a query reply nobody awaits: see below
            self._on_unsolicited(event)
            return
        # Bytes no exchange awaits, shaped like a reply: one more came than was asked for.
        # The line is out of step until it has been quiet long enough (``Link.resync``).
        self.step_out(late=True)
        if isinstance(event, Garbled):
            self._counters.garbled += 1
        elif isinstance(event, ChecksumMismatch):
            self._counters.checksum_errors += 1
        self._on_stray(event, self.last_body)
