"""Exactly one exchange at a time on one loop's port (DESIGN invariant 1).

``Link.exchange`` is the only way a frame reaches the port. For each frame it: waits for a
message still arriving to end, takes the bytes nobody read yet off the port (stale input:
counted, traced, and still searched for ``$B#*``/``$B#T`` and, while a program may print,
its lines), registers the expected reply with the parser *before* writing, writes, and waits
the reply time-out that ``timing`` computes from the baud rate and the frame lengths.

After a time-out the line is out of step (DESIGN invariant 13) until it is brought back: the
expectation is kept while the line is busy and until it has been quiet for the longest reply
any controller of the loop can send, plus the turnaround (``Timing.resync_quiet``): a reply
that completes then is the command's own reply, counted as late; anything else that arrives
then is counted as late and dropped. Only then does the next frame go out, after the stale
input is discarded, so a late reply is never taken for the next command's reply. A reply
that does not fit its command's form, or bytes that come after an exchange has ended, put
the line out of step the same way: ``resync`` waits for that silence before the next frame.

The reading side (reader task, parser, routing) is ``receiver.Receiver``.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable
from dataclasses import dataclass

from gateway.bus.receiver import ALWAYS_MEANT, LinkLost, Pending, Receiver
from gateway.bus.trace import FrameDirection
from gateway.protocol.framing import Framing, Series
from gateway.protocol.reply_parser import ReplyEvent, Unsolicited
from gateway.transport.base import TransportClosed

__all__ = ["Exchange", "Link", "LinkLost"]

#: Quiet periods a resync waits at most for silence: a line that never falls quiet (noise, a
#: program printing without end) is left out of step rather than holding every frame back.
_RESYNC_PERIODS = 4


@dataclass(frozen=True)
class Exchange:
    """What one frame got: its reply event (None: time-out), and how."""

    event: ReplyEvent | None
    late: bool  # the reply completed after its time-out
    heard: bool  # any byte came in between the write and the end
    started: float
    ended: float


class Link(Receiver):
    """The port of one loop: exactly one exchange at a time (see the module's text)."""

    # ------------------------------------------------------------------ one exchange

    async def exchange(
        self,
        body: str,
        frame: bytes,
        *,
        has_data: bool,
        framing: Framing,
        series: Series,
        reply_len: int,
        expect_sent: bytes | None = None,
        sent_before: int = 0,
    ) -> Exchange:
        """Write ``frame`` to ``body`` and wait for its reply (see the module's text).

        ``framing`` is the framing of the reply (``framing_switch(...).reply`` for EL);
        ``expect_sent`` is the echo the parser compares (default ``frame``; program text has
        none); ``sent_before``: bytes written just before that are still on the wire (program
        text pieces). ``LinkLost`` when the port goes away meanwhile.
        """
        if self.lost_cause is not None:
            raise LinkLost(self.lost_cause)
        await self._settle()
        if self.out_of_step:
            await self.resync(body, len(frame) if framing.echo else 0)
        self._discard_stale(body)
        self.parser.configure(framing=framing, series=series, printing=self.programs.printing)
        self.parser.expect(
            body, frame if expect_sent is None else expect_sent, has_data, framing=framing
        )
        event_loop = asyncio.get_running_loop()
        pending = Pending(body, event_loop.create_future())
        self._pending = pending
        started = self._clock()
        try:
            self._write(body, frame, started)
            limit = self.timing.real(self.timing.reply_timeout(sent_before + len(frame), reply_len))
            await pending.wait(limit)
            late = False
            if not pending.future.done():
                echoed = sent_before + len(frame) if framing.echo else 0
                late = await self._late_window(pending, reply_len, limit, echoed)
            if pending.future.done():
                event: ReplyEvent | None = pending.future.result()  # raises LinkLost
            else:
                event = None
                self.parser.cancel()
                self._counters.timeouts += 1
                if not pending.heard:
                    self.silent_timeouts += 1
                self._trace.add(self._clock(), FrameDirection.NOTE, body, b"", "time-out")
            if late:
                self._counters.late_replies += 1
                self._trace.add(self._clock(), FrameDirection.NOTE, body, b"", "late reply")
            return Exchange(event, late, pending.heard, started, self._clock())
        finally:
            self._pending = None
            if not pending.future.done():
                pending.future.cancel()

    async def _late_window(
        self, pending: Pending, reply_len: int, limit: float, echoed: int
    ) -> bool:
        """After the time-out: keep the expectation until the line has been quiet for the
        longest reply of the loop (``Timing.resync_quiet``): the line is back in step then.

        True when the reply completed in this window (it is the command's own: every earlier
        exchange ended in step). A line that never falls quiet (noise) ends the window after
        ``limit`` and a few quiet periods, still out of step: the next exchange waits again.
        """
        pending.late_phase = True
        base = max(self.timing.late_quiet(reply_len), self.timing.resync_quiet(echoed))
        quiet = self.lateness.quiet(base)
        event_loop = asyncio.get_running_loop()
        began = event_loop.time()
        self.lateness.timed_out(began)
        end = began + limit + _RESYNC_PERIODS * quiet
        settled = False
        first_chunk = self._rx_chunks
        while not pending.future.done() and event_loop.time() < end:
            mark = self._rx_chunks
            await pending.wait(min(quiet, max(0.0, end - event_loop.time())))
            if self._rx_chunks == mark:  # a whole quiet period without a byte
                settled = True
                break
        if not pending.future.done():
            for event in self.parser.line_quiet():  # a reply cut short may end here
                self._route(event)
            self._idle.set()
            self.out_of_step = not settled
            if settled and self._rx_chunks == first_chunk:
                self.lateness.silent()
        else:
            self.lateness.arrived(event_loop.time())  # its own reply, this late
        self.resync_time += event_loop.time() - began
        self.resyncs += 1
        return pending.future.done() and pending.future.exception() is None

    async def resync(self, body: str, echoed: int = 0) -> None:
        """Bring the line back in step: wait until it has been quiet for the longest reply of
        the loop; what arrives meanwhile is counted late and dropped (DESIGN invariant 13).
        ``echoed``: the length of a frame an EE1 controller echoes before its reply."""
        quiet = self.lateness.quiet(self.timing.resync_quiet(echoed))
        event_loop = asyncio.get_running_loop()
        began = event_loop.time()
        end = began + _RESYNC_PERIODS * quiet
        first_chunk = self._rx_chunks
        self.resyncing = True
        self._trace.add(self._clock(), FrameDirection.NOTE, body, b"", "resync")
        try:
            while event_loop.time() < end and self.lost_cause is None:
                mark = self._rx_chunks
                await self._quiet_for(min(quiet, end - event_loop.time()))
                if self._rx_chunks == mark:
                    self.out_of_step = False
                    if mark == first_chunk:
                        self.lateness.silent()
                    break
            for event in self.parser.line_quiet():
                self._route(event)
            self._idle.set()
        finally:
            self.resyncing = False
            self.resync_time += event_loop.time() - began
            self.resyncs += 1
        if self.lost_cause is not None:
            raise LinkLost(self.lost_cause)

    async def _quiet_for(self, seconds: float) -> None:
        """Wait ``seconds`` (the line's silence is judged by the chunks received meanwhile);
        woken early only when the line is lost."""
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(self.lost.wait(), max(0.0, seconds))

    async def _settle(self) -> None:
        """Wait (at most one quiet period) for a message still arriving to end."""
        if not self._idle.is_set():
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._idle.wait(), self.timing.quiet() * 2)
            if not self._idle.is_set():
                self._line_quiet()

    def _discard_stale(self, body: str) -> None:
        """Bytes nobody read yet: counted, traced, searched for unsolicited messages."""
        stale = self.transport.discard_input()
        if not stale:
            return
        self._counters.stale_bytes += len(stale)
        self._counters.bytes_in += len(stale)
        self._counters.busy_time += self.timing.wire(len(stale))
        self._trace.add(self._clock(), FrameDirection.DISCARD, body, stale, "stale")
        self.parser.cancel()
        for event in [*self.parser.feed(stale), *self.parser.line_quiet()]:
            if isinstance(event, Unsolicited) and (
                event.kind in ALWAYS_MEANT or self._printed(event)
            ):
                self._on_unsolicited(event)
        self._idle.set()

    def _write(self, body: str, data: bytes, now: float) -> None:
        try:
            self.transport.write(data)
        except TransportClosed as exc:
            self.lose(f"transport closed: {exc}")
            raise LinkLost(self.lost_cause or str(exc)) from exc
        self._last_frame = data
        self._counters.bytes_out += len(data)
        self._counters.busy_time += self.timing.wire(len(data))
        if self._trace.on:
            self._trace.add(now, FrameDirection.TX, body, data)

    async def probe(
        self, body: str, frame: bytes, *, reply_len: int, complete: Callable[[bytes], bool]
    ) -> bytes:
        """Write ``frame`` and return the raw bytes that answer it, bypassing the parser.

        For reading a controller's framing back when it is in doubt: waits until
        ``complete(bytes)`` says the answer is in, or the time-out for ``reply_len``
        characters has passed.
        """
        if self.lost_cause is not None:
            raise LinkLost(self.lost_cause)
        await self._settle()
        if self.out_of_step:
            await self.resync(body)
        self._discard_stale(body)
        self.parser.cancel()
        event_loop = asyncio.get_running_loop()
        self._probe = buffer = bytearray()
        try:
            self._write(body, frame, self._clock())
            deadline = event_loop.time() + self.timing.real(
                self.timing.reply_timeout(len(frame), reply_len)
            )
            while not complete(bytes(buffer)) and self.lost_cause is None:
                left = deadline - event_loop.time()
                if left <= 0:
                    break
                self._probe_changed.clear()
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._probe_changed.wait(), left)
            if self.lost_cause is not None:
                raise LinkLost(self.lost_cause)
            if not complete(bytes(buffer)):
                self._counters.timeouts += 1
                self._trace.add(
                    self._clock(), FrameDirection.NOTE, body, bytes(buffer), "probe time-out"
                )
            return bytes(buffer)
        finally:
            self._probe = None

    @property
    def pending_body(self) -> str | None:
        """The controller whose reply is awaited now, if any."""
        return self._pending.body if self._pending is not None else None

    def is_echo(self, raw: bytes) -> bool:
        """Whether ``raw`` is the last frame written, come back (EE1 that was not expected)."""
        return bool(raw) and raw == self._last_frame

    def write_raw(self, body: str, data: bytes) -> None:
        """Write bytes that expect no reply of their own (program text pieces before its CR)."""
        if self.lost_cause is not None:
            raise LinkLost(self.lost_cause)
        self._write(body, data, self._clock())
