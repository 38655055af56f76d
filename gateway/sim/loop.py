"""The simulated current loop: 1-15 controllers on one line, with wire timing and faults.

Every controller hears every frame; only the addressed one answers, an absent body number gets
no answer (§3-III, §9-1). One ``CommandReader`` reads the host's bytes for the whole loop and is
kept in step with each controller's SUM switch and program transfer (§10 SUM, §10 I).

Timing (simulated seconds; ``SimClock`` turns them into real ones): a host byte arrives 10 bits
after the previous one at the line's baud rate (8N1, §2); a frame is executed when its CR
arrives; the reply starts ``turnaround`` later and arrives at the host after its own 10 bits a
character, i.e. ``(len(frame) + len(reply)) * 10 / baud + turnaround`` after the host wrote the
frame. The return line carries one message at a time: replies and unsolicited messages
(``$B#*`` ...) queue for it in the order they are ready and never interleave.

Baud rates (§10 ES): a controller at another rate than the line hears noise (communication
error, no answer); what it sends reaches the host as ``faults.uart_noise``. The reply to ``ES``
itself still goes out at the rate the command came in at. A controller whose body switch is
'F' is in inspection mode (§3-III): it echoes what it hears, at 9600 (§10 ES 注意点 has the
host at 9600 for it), and a lone '/' erases its EEPROM.

Everything that passes is written to ``log`` (``clock.LineRecord``), which tests and the
control surface read. ``attach`` connects the host end (one at a time); ``serve`` has the in-process
port, the pseudo-terminal and the TCP server built on it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from gateway.protocol.framing import (
    CommandEvent,
    CommandFrame,
    CommandReader,
    Framing,
    RawText,
    Series,
)
from gateway.sim.clock import LineLog, RecordKind, Scheduler, SimClock
from gateway.sim.faults import Draw, FaultKind, FaultRule, Faults, garble, uart_noise
from gateway.sim.memory import Baud

__all__ = [
    "INSPECTION",
    "Device",
    "HostLink",
    "LineBusy",
    "SimLoop",
    "Unit",
]

#: The body switch position of the inspection mode (§3-III).
INSPECTION = "F"
#: Bits per character on the line: start, 8 data, stop (§2: 8N1).
BITS_PER_CHAR = 10
#: The rate of a controller in inspection mode (§10 ES 注意点: the host is set to 9600 for it).
INSPECTION_BAUD = 9600


class LaterLike(Protocol):
    """An unsolicited message (``controller.Later``)."""

    @property
    def at(self) -> float:
        """Simulated time the controller sends it."""

    @property
    def data(self) -> bytes:
        """The bytes."""

    def wanted(self) -> bool:
        """False when the message was called off meanwhile (asked at ``at``)."""


class ResponseLike(Protocol):
    """What a controller answers to a frame (``controller.Response``)."""

    @property
    def reply(self) -> bytes:
        """The reply; b"" = silent."""

    @property
    def later(self) -> Sequence[LaterLike]:
        """Unsolicited messages it will send by itself."""


class Device(Protocol):
    """What the loop needs of a controller (``controller.Controller``)."""

    body: str  # the body switch as the controller reads it at power-on

    @property
    def series(self) -> Series:
        """'$' or '#' (§9-1 注意)."""

    @property
    def baud(self) -> Baud:
        """Its ES rate."""

    @property
    def framing(self) -> Framing:
        """Its EE/EL/ER/SUM switches."""

    @property
    def awaiting_program(self) -> bool:
        """True after ``I`` was taken: program text follows (§10 I)."""

    def receive(self, event: CommandFrame | RawText, now: float) -> ResponseLike:
        """Act on a frame addressed to it."""

    def note_noise(self, now: float) -> None:
        """A frame reached it garbled (communication error)."""

    def power_cycle(self, now: float) -> ResponseLike:
        """Power on again: RAM lost, EEPROM kept."""

    def inspect(self, data: bytes, now: float) -> bytes:
        """Inspection mode: what it echoes for ``data`` (a lone '/' erases its EEPROM)."""

    def set_ems(self, now: float, pressed: bool) -> None:
        """Press or release its emergency stop switch."""

    def force_sensor(self, now: float, motor: int, sensor: str, on: bool | None) -> None:
        """Force a sensor ON/OFF (None: back to the scene)."""

    def slip(self, now: float, motor: int, pulses: int) -> None:
        """Lose pulses on a motor (step-out)."""

    def set_input(self, now: float, bit: int, on: bool) -> None:
        """Drive a general input."""

    def snapshot(self, now: float) -> dict[str, Any]:
        """JSON-ready state."""


class LineBusy(RuntimeError):
    """A second host tried to connect: the line takes one host at a time."""


@dataclass
class Unit:
    """One controller on the loop: its name, power and body switch."""

    device: Device
    name: str  # the body number it was given at start; stays when the switch is turned
    switch: str  # the body switch; read at the next power-on
    on: bool = True
    generation: int = 0  # counts power-offs: a message of an older generation is lost

    @property
    def inspecting(self) -> bool:
        """Body switch F at power-on: inspection mode (§3-III)."""
        return self.device.body == INSPECTION

    @property
    def bps(self) -> int:
        """The rate it talks at."""
        return INSPECTION_BAUD if self.inspecting else self.device.baud.bps


@dataclass(frozen=True)
class _Message:
    """Bytes a controller puts on the return line."""

    unit: Unit
    data: bytes
    kind: RecordKind
    ref: int = 0  # the host frame it answers
    draw: Draw | None = None  # faults drawn for that frame (device events follow the reply)
    bps: int = 0  # the rate it is sent at (0: the unit's rate now)
    generation: int = field(default=-1, compare=False)

    def __post_init__(self) -> None:
        # A message belongs to the power-on it was made in; sent at the unit's rate by default.
        if self.generation < 0:
            object.__setattr__(self, "generation", self.unit.generation)
        if not self.bps:
            object.__setattr__(self, "bps", self.unit.bps)


class HostLink:
    """The host end of the line: ``write`` puts bytes on it, ``close`` lets another host on."""

    def __init__(self, loop: SimLoop, sink: Callable[[bytes], None]) -> None:
        self._loop = loop
        self.sink = sink
        self.closed = False

    def write(self, data: bytes) -> None:
        """Send bytes to the controllers (they arrive at the line's baud rate)."""
        if not self.closed:
            self._loop.host_write(data)

    def close(self) -> None:
        """Disconnect; bytes still on their way to the host are lost."""
        if not self.closed:
            self.closed = True
            self._loop.detach(self)


class SimLoop:
    """The controllers, the line between them and the host, and the faults on it."""

    def __init__(
        self,
        devices: Iterable[Device],
        *,
        clock: SimClock | None = None,
        baud: int = 9600,
        turnaround: float = 0.001,
        faults: Faults | None = None,
    ) -> None:
        self.units = [Unit(d, d.body, d.body) for d in devices]
        names = [u.name for u in self.units]
        if len(set(names)) != len(names):
            raise ValueError(f"body numbers must differ: {names}")
        self.clock = clock or SimClock()
        self.scheduler = Scheduler(self.clock)
        self.baud = baud
        self.turnaround = turnaround
        self.faults = faults or Faults()
        self.log = LineLog()
        self.cut = False
        self._reader = CommandReader()
        self._sums: set[tuple[Series, str]] = set()
        self._frames = 0
        self._in_free = 0.0  # host -> controllers line busy until
        self._out_free = 0.0  # controllers -> host line busy until
        self._host: HostLink | None = None
        self._sync_reader()

    # ------------------------------------------------------------------ time

    def now(self) -> float:
        """Simulated time now (never earlier than anything already done)."""
        return self.scheduler.now()

    def char_time(self, bps: int | None = None) -> float:
        """Seconds one character takes on the wire at ``bps`` (default: the line's rate)."""
        return BITS_PER_CHAR / (bps or self.baud)

    def act(self, action: Callable[[float], None]) -> float:
        """Run ``action(now)`` after everything due; the control surface's way in."""
        now = self.now()
        self.scheduler.run_due(now)
        action(now)
        self._sync_reader()
        self.scheduler.kick()
        return now

    def close(self) -> None:
        """Stop the timer and disconnect the host; the loop does nothing more."""
        self.scheduler.close()
        if self._host is not None:
            self._host.close()

    # ------------------------------------------------------------------ the host end

    def attach(self, sink: Callable[[bytes], None]) -> HostLink:
        """Connect the host: ``sink`` gets every byte that reaches it. One host at a time."""
        if self._host is not None:
            raise LineBusy("the line already has a host")
        self._host = HostLink(self, sink)
        self.log.add(self.now(), RecordKind.HOST, note="connected")
        return self._host

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
            self.scheduler.at(at, self._hear, byte, at)
        self._in_free = start + len(data) * char
        self.scheduler.kick()

    # ------------------------------------------------------------------ hearing

    def _hear(self, byte: int, now: float) -> None:
        if self.cut:  # nothing passes a cut line
            self.log.add(now, RecordKind.LOST, bytes([byte]), note="line cut")
            return
        self._reader.push(bytes([byte]))
        while (event := self._reader.next_event()) is not None:
            self._handle(event, now)
            self._sync_reader()

    def _handle(self, event: CommandEvent, now: float) -> None:
        frame = event if isinstance(event, CommandFrame | RawText) else None
        body = frame.body if frame else None
        ref = 0
        if frame:
            self._frames += 1
            ref = self._frames
        self.log.add(now, RecordKind.HEARD, event.raw, body=body, ref=ref)
        target: Unit | None = None
        why = "absent"
        for unit in self.units:
            addressed = frame is not None and (unit.device.series, unit.device.body) == (
                frame.series,
                frame.body,
            )
            if not unit.on:
                why = "off" if addressed else why
            elif unit.inspecting:
                if unit.bps == self.baud:  # else it hears noise, and echoes nothing useful
                    echo = unit.device.inspect(event.raw, now)
                    self._transmit(_Message(unit, echo, RecordKind.ECHO), now)
            elif unit.bps != self.baud:
                unit.device.note_noise(now)  # §10 9 bit 0: noise error
                why = "other baud" if addressed else why
            elif addressed:
                target = unit
        if frame is None:
            return
        if target is None:
            self.log.add(now, RecordKind.NONE, body=body, ref=ref, note=why)
        else:
            self._answer(target, frame, ref, now)

    def _answer(self, unit: Unit, event: CommandFrame | RawText, ref: int, now: float) -> None:
        device = unit.device
        bps = unit.bps  # the reply to ES still goes out at the old rate (§10 ES; notes)
        draw = self.faults.draw(device.body)
        later: tuple[LaterLike, ...] = ()
        if draw.kind is FaultKind.NAK:
            # §9-2: '?' = the communication was abnormal; the frame is not executed.
            device.note_noise(now)
            reply = b"?"
        else:
            response = device.receive(event, now)
            reply, later = response.reply, tuple(response.later)
        if device.awaiting_program:
            self._reader.begin_raw(device.body, series=device.series)
        for message in later:
            self.scheduler.at(message.at, self._later, unit, unit.generation, message)
        if draw.line is not None:
            self.log.add(now, RecordKind.FAULT, body=device.body, ref=ref, note=draw.line.kind)
        ready = now + self.turnaround
        if draw.line is not None and draw.line.kind is FaultKind.LATE:
            ready += draw.line.delay
        if not reply or draw.kind is FaultKind.DROP:
            note = "dropped" if reply else "silent"
            self.log.add(now, RecordKind.NONE, body=device.body, ref=ref, note=note)
            self._after(draw, unit, ready + len(reply) * self.char_time(bps))
            return
        if draw.kind is FaultKind.GARBLE:
            reply = garble(reply, self.faults.rng)
        self.scheduler.at(
            ready, self._transmit, _Message(unit, reply, RecordKind.REPLY, ref, draw, bps), ready
        )

    def _later(self, unit: Unit, generation: int, message: LaterLike) -> None:
        if unit.on and unit.generation == generation and message.wanted():
            self._transmit(_Message(unit, message.data, RecordKind.LATER), self.scheduler.time)

    # ------------------------------------------------------------------ sending

    def _transmit(self, message: _Message, ready: float) -> None:
        """Put a message on the return line once it is free; it reaches the host at the end."""
        start = max(ready, self._out_free)
        end = start + len(message.data) * self.char_time(message.bps)
        self._out_free = end
        self.scheduler.at(end, self._deliver, message, end)

    def _deliver(self, message: _Message, now: float) -> None:
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
            self.log.add(now, message.kind, heard, body=unit.device.body, ref=ref)
            assert self._host is not None
            self._host.sink(heard)
        if message.draw is not None:
            self._after(message.draw, unit, now)

    def _after(self, draw: Draw, unit: Unit, at: float) -> None:
        """Schedule the device events of ``draw`` for when the reply has left."""
        for rule in draw.events:
            self.scheduler.at(at, self._event, unit, rule)

    def _event(self, unit: Unit, rule: FaultRule) -> None:
        """Apply one drawn device event (faults.DEVICE_FAULTS) at the current time."""
        now, device = self.scheduler.time, unit.device
        self.log.add(now, RecordKind.FAULT, body=device.body, note=rule.kind)
        if rule.kind is FaultKind.POWER:
            self.power_cycle(unit, now, rule.hold)
        elif rule.kind is FaultKind.CUT:
            self.cut_for(rule.hold, now)
        elif rule.kind is FaultKind.EMS:
            device.set_ems(now, True)
            self.scheduler.at(now + rule.hold, lambda: device.set_ems(self.scheduler.time, False))
        elif rule.kind is FaultKind.SENSOR:
            device.force_sensor(now, rule.motor, rule.sensor, rule.on)
            self.scheduler.at(
                now + rule.hold,
                lambda: device.force_sensor(self.scheduler.time, rule.motor, rule.sensor, None),
            )
        elif rule.kind is FaultKind.SLIP:
            device.slip(now, rule.motor, rule.pulses)

    # ------------------------------------------------------------------ the bus

    def unit(self, body: str) -> Unit:
        """The unit whose switch is at ``body``, else the one started as ``body``."""
        for unit in self.units:
            if unit.switch == body:
                return unit
        for unit in self.units:
            if unit.name == body:
                return unit
        raise KeyError(f"no controller {body!r} on the loop")

    def power(self, unit: Unit, on: bool, now: float) -> None:
        """Switch ``unit`` off (it stops hearing and talking) or on (power-on with its switch)."""
        if on == unit.on:
            return
        unit.on = on
        if not on:
            unit.generation += 1
            self.log.add(now, RecordKind.POWER, body=unit.device.body, note="off")
            return
        unit.device.body = unit.switch
        self.log.add(now, RecordKind.POWER, body=unit.switch, note="on")
        if unit.inspecting:
            return
        response = unit.device.power_cycle(now)
        if response.reply:
            self._transmit(_Message(unit, response.reply, RecordKind.LATER), now)
        for message in response.later:
            self.scheduler.at(message.at, self._later, unit, unit.generation, message)

    def power_cycle(self, unit: Unit, now: float, off_for: float = 0.0) -> None:
        """Off now, on again ``off_for`` seconds later."""
        self.power(unit, False, now)
        if off_for <= 0:
            self.power(unit, True, now)
        else:
            self.scheduler.at(now + off_for, self._power_on, unit)

    def _power_on(self, unit: Unit) -> None:
        self.power(unit, True, self.scheduler.time)
        self._sync_reader()

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

    def _sync_reader(self) -> None:
        """Tell the reader which bodies send checksums (§10 SUM) after every change."""
        sums = {
            (u.device.series, u.device.body)
            for u in self.units
            if u.on and not u.inspecting and u.device.framing.checksum
        }
        for series, body in self._sums - sums:
            self._reader.set_checksum(body, False, series=series)
        for series, body in sums - self._sums:
            self._reader.set_checksum(body, True, series=series)
        self._sums = sums

    def state(self) -> dict[str, Any]:
        """A JSON-ready view of the loop and its controllers."""
        now = self.now()
        self.scheduler.run_due(now)
        return {
            "time": now,
            "time_scale": self.clock.scale,
            "baud": self.baud,
            "turnaround": self.turnaround,
            "cut": self.cut,
            "host": self._host is not None,
            "faults": self.faults.describe(),
            "units": [
                {
                    "name": u.name,
                    "switch": u.switch,
                    "on": u.on,
                    "inspection": u.inspecting,
                    "controller": u.device.snapshot(now) if u.on and not u.inspecting else None,
                }
                for u in self.units
            ],
        }
