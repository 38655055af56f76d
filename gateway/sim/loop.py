"""The simulated current loop: 1-15 controllers on one line, with wire timing and faults.

Every controller hears every frame; only the addressed one answers, an absent body number gets
no answer (§3-III, §9-1). One ``CommandReader`` reads the host's bytes for the whole loop and is
kept in step with each controller's SUM switch and program transfer (§10 SUM, §10 I).

Timing: a frame is executed when its CR arrives (the wire, ``line.Line``, brings the bytes);
the reply starts ``turnaround`` later and arrives at the host after its own 10 bits a
character, i.e. ``(len(frame) + len(reply)) * 10 / baud + turnaround`` after the host wrote the
frame.

Baud rates (§10 ES): a controller at another rate than the line hears noise (communication
error, no answer); what it sends reaches the host as ``faults.uart_noise``. The reply to ``ES``
itself still goes out at the rate the command came in at. A controller whose body switch is
'F' is in inspection mode (§3-III): it echoes what it hears, at 9600 (§10 ES 注意点 has the
host at 9600 for it), and a lone '/' erases its EEPROM.

User programs (§11-3): a controller whose program runs is woken at the simulated times it
asks for (``Device.wake_at``: a statement, the end of a motion or of the timer) and what the
program sends goes on the return line like ``$B#*``, one whole message at a time, behind a
reply already going out. After a control action or a device fault the controllers are nudged,
so that a program polling an input sees the change.

The wire itself (byte timing, the return line, cuts, the host end, the ``log``) is
``line.Line``; the controllers as the loop sees them are ``units``. ``serve`` has the in-process
port, the pseudo-terminal and the TCP server built on the loop.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from gateway.protocol.command_reader import CommandEvent, CommandFrame, CommandReader, RawText
from gateway.protocol.framing import Series
from gateway.sim.clock import RecordKind, SimClock
from gateway.sim.faults import Draw, FaultKind, FaultRule, Faults, garble
from gateway.sim.line import HostLink, Line, LineBusy
from gateway.sim.units import INSPECTION, Device, LaterLike, Message, Unit

# The loop's users (serve, control, tests) get the parts they handle from here as well.
__all__ = [
    "INSPECTION",
    "HostLink",
    "LineBusy",
    "SimLoop",
    "Unit",
]


class SimLoop(Line):
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
        super().__init__(clock, baud)
        self.turnaround = turnaround
        self.faults = faults or Faults()
        self._reader = CommandReader()
        self._sums: set[tuple[Series, str]] = set()
        self._frames = 0
        self._sync_reader()
        for unit in self.units:  # a program GA started at power-on (§10 GA)
            self._arm(unit)

    def act(self, action: Callable[[float], None]) -> float:
        """Run ``action(now)`` after everything due; the control surface's way in."""
        now = self.now()
        self.scheduler.run_due(now)
        action(now)
        for unit in self.units:
            self._nudge(unit, now)
        self._sync_reader()
        self.scheduler.kick()
        return now

    # ------------------------------------------------------------------ hearing

    def _hear(self, byte: int, now: float) -> None:
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
                    self._transmit(Message(unit, echo, RecordKind.ECHO), now)
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
            ready, self._transmit, Message(unit, reply, RecordKind.REPLY, ref, draw, bps), ready
        )
        self._arm(unit)

    # ------------------------------------------------------------------ user programs

    def _arm(self, unit: Unit) -> None:
        """Schedule the next wake of ``unit``'s program, if it asks for one."""
        at = unit.device.wake_at() if unit.on and not unit.inspecting else None
        if at == unit.wake_time:
            return
        unit.wake_token += 1
        unit.wake_time = at
        if at is not None:
            self.scheduler.at(at, self._wake, unit, unit.generation, unit.wake_token)

    def _wake(self, unit: Unit, generation: int, token: int) -> None:
        if token != unit.wake_token or generation != unit.generation or not unit.on:
            return
        unit.wake_time = None
        for message in unit.device.wake(self.scheduler.time):
            self.scheduler.at(message.at, self._later, unit, unit.generation, message)
        self._sync_reader()  # a program may switch SUM (§10 SUM in programs)
        self._arm(unit)

    def _nudge(self, unit: Unit, now: float) -> None:
        """Something outside changed: a program polling in a loop looks again."""
        if unit.on and not unit.inspecting:
            unit.device.nudge(now)
            self._arm(unit)

    def _later(self, unit: Unit, generation: int, message: LaterLike) -> None:
        if unit.on and unit.generation == generation and message.wanted():
            self._transmit(Message(unit, message.data, RecordKind.LATER), self.scheduler.time)

    def _sent(self, message: Message, now: float) -> None:
        if message.draw is not None:
            self._after(message.draw, message.unit, now)

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
        self._nudge(unit, now)

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
            unit.device.power_off(now)
            self.log.add(now, RecordKind.POWER, body=unit.device.body, note="off")
            return
        unit.device.body = unit.switch
        self.log.add(now, RecordKind.POWER, body=unit.switch, note="on")
        if unit.inspecting:
            return
        response = unit.device.power_cycle(now)
        if response.reply:
            self._transmit(Message(unit, response.reply, RecordKind.LATER), now)
        for message in response.later:
            self.scheduler.at(message.at, self._later, unit, unit.generation, message)
        unit.wake_time = None  # wakes of the last power-on are stale (generation)
        self._arm(unit)  # autostart (§10 GA)

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
