"""The wire of the simulated current loop: host bytes out at the line's rate, messages back.

Timing (simulated seconds; ``SimClock`` turns them into real ones): a host byte arrives 10 bits
after the previous one at the line's baud rate (8N1, §2). The return line carries one message at
a time: replies and unsolicited messages (``$B#*`` ...) queue for it in the order they are ready
and never interleave; each reaches the host after 10 bits a character at the rate it was sent
at. A message sent at another rate than the line's reaches the host as ``faults.uart_noise``.
A cut line passes nothing either way.

Everything that passes is written to ``log`` (``clock.LineRecord``), which tests and the control
surface read. ``attach`` connects the host end (one at a time). ``Line`` is the wire alone:
``loop.SimLoop`` puts the controllers on it and decides what they hear and answer.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable

from gateway.protocol.framing import BITS_PER_CHAR
from gateway.sim.clock import LineLog, RecordKind, Scheduler, SimClock
from gateway.sim.faults import uart_noise
from gateway.sim.units import Message

__all__ = ["BITS_PER_CHAR", "HostLink", "Line", "LineBusy"]


class LineBusy(RuntimeError):
    """A second host tried to connect: the line takes one host at a time."""


class HostLink:
    """The host end of the line: ``write`` puts bytes on it, ``close`` lets another host on."""

    def __init__(
        self,
        line: Line,
        sink: Callable[[bytes], None],
        on_close: Callable[[], None] | None = None,
    ) -> None:
        self._line = line
        self.sink = sink
        self.closed = False
        self._on_close = on_close  # told when the link ends, whoever ends it

    def write(self, data: bytes) -> None:
        """Send bytes to the controllers (they arrive at the line's baud rate)."""
        if not self.closed:
            self._line.host_write(data)

    def close(self) -> None:
        """Disconnect; bytes still on their way to the host are lost."""
        if not self.closed:
            self.closed = True
            self._line.detach(self)
            if self._on_close is not None:
                self._on_close()


class Line(ABC):
    """The wire between the host and the controllers: its timing, the host end, cuts."""

    def __init__(self, clock: SimClock | None, baud: int) -> None:
        self.clock = clock or SimClock()
        self.scheduler = Scheduler(self.clock)
        self.baud = baud
        self.log = LineLog()
        self.cut = False
        self._in_free = 0.0  # host -> controllers line busy until
        self._out_free = 0.0  # controllers -> host line busy until
        self._host: HostLink | None = None

    @abstractmethod
    def _hear(self, byte: int, now: float) -> None:
        """A host byte reaches the controllers over the intact line."""

    @abstractmethod
    def _sent(self, message: Message, now: float) -> None:
        """``message`` has left the return line, delivered or lost: what follows it."""

    # ------------------------------------------------------------------ time

    def now(self) -> float:
        """Simulated time now (never earlier than anything already done)."""
        return self.scheduler.now()

    def char_time(self, bps: int | None = None) -> float:
        """Seconds one character takes on the wire at ``bps`` (default: the line's rate)."""
        return BITS_PER_CHAR / (bps or self.baud)

    def close(self) -> None:
        """Stop the timer and disconnect the host; the loop does nothing more."""
        self.scheduler.close()
        if self._host is not None:
            self._host.close()

    # ------------------------------------------------------------------ the host end

    def attach(
        self, sink: Callable[[bytes], None], on_close: Callable[[], None] | None = None
    ) -> HostLink:
        """Connect the host: ``sink`` gets every byte that reaches it. One host at a time.

        ``on_close`` is called when the link ends, also when the loop itself closes (the host
        sees its line go away).
        """
        if self._host is not None:
            raise LineBusy("the line already has a host")
        self._host = HostLink(self, sink, on_close)
        self.log.add(self.now(), RecordKind.HOST, note="connected")
        return self._host

    def drop_host(self) -> None:
        """Disconnect the host, as a serial device server does when it restarts."""
        if self._host is not None:
            self._host.close()

    def detach(self, link: HostLink) -> None:
        """Disconnect ``link`` (``HostLink.close`` calls this)."""
        if self._host is link:
            self._host = None
            self.log.add(self.now(), RecordKind.HOST, note="disconnected")

    def host_write(self, data: bytes) -> None:
        """Bytes from the host, sent now: each arrives one character time after the last."""
        if self.scheduler.closed:
            return
        now = self.now()
        self.scheduler.run_due(now)
        start = max(now, self._in_free)
        char = self.char_time()
        for i, byte in enumerate(data):
            at = start + (i + 1) * char
            self.scheduler.at(at, self._arrive, byte, at)
        self._in_free = start + len(data) * char
        self.scheduler.kick()

    def _arrive(self, byte: int, now: float) -> None:
        if self.cut:  # nothing passes a cut line
            self.log.add(now, RecordKind.LOST, bytes([byte]), note="line cut")
            return
        self._hear(byte, now)

    # ------------------------------------------------------------------ sending

    def _transmit(self, message: Message, ready: float) -> None:
        """Put a message on the return line once it is free; it reaches the host at the end."""
        start = max(ready, self._out_free)
        end = start + len(message.data) * self.char_time(message.bps)
        self._out_free = end
        self.scheduler.at(end, self._deliver, message, end)

    def _deliver(self, message: Message, now: float) -> None:
        unit, ref = message.unit, message.ref
        lost = ""
        if unit.generation != message.generation:
            lost = "power off"
        elif self.cut:
            lost = "line cut"
        elif self._host is None:
            lost = "no host"
        if lost:
            kind = RecordKind.NONE if ref else RecordKind.LOST
            self.log.add(now, kind, message.data, body=unit.device.body, ref=ref, note=lost)
        else:
            heard = uart_noise(message.data, message.bps, self.baud)
            late = self.clock.now() - now  # the timer's lateness: the host gets it now
            self.log.add(now, message.kind, heard, body=unit.device.body, ref=ref, late=late)
            assert self._host is not None
            self._host.sink(heard)
        self._sent(message, now)

    # ------------------------------------------------------------------ cuts

    def set_cut(self, cut: bool, now: float) -> None:
        """Cut the line (nothing passes either way) or restore it."""
        self.cut = cut
        self.log.add(now, RecordKind.CUT, note="cut" if cut else "restored")

    def _restore(self) -> None:
        self.set_cut(False, self.scheduler.time)

    def cut_for(self, hold: float, now: float) -> None:
        """Cut the line now and restore it ``hold`` seconds later."""
        self.set_cut(True, now)
        self.scheduler.at(now + hold, self._restore)
