"""One simulated RC-233: receives command frames, applies the manual's rules, answers.

The controller parses every frame with the gateway's own ``gateway.protocol.parse`` and answers
with its encoders, so a command the catalog refuses is exactly a command the simulated device
ignores with the command-error flag (§9-1 注意). The order of the checks, all from the manual:

1. powered off, or busy erasing the EEPROM (``EE///``, §10 EE///): silence;
2. SUM1 and a bad checksum: ``?`` (§10 SUM);
3. text that fits no form, or a bad parameter: ignored, command error (§9-1 注意);
4. a rule of ``rules.check_rules`` broken (a user program runs, the mode, a motor moves):
   ignored, command error;
5. the form's handler (``dispatch.HANDLERS``), which may refuse in turn (out-of-rule settings).

Time is simulated seconds passed in by the caller (``now``); the controller never reads a clock.
Motion is evaluated lazily: before each command the axes are advanced to ``now`` and what
happened meanwhile (limit or EMS stops, homing completions) is latched into the flags.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

from gateway.errors import InvalidInputError
from gateway.protocol.command_reader import CommandFrame, RawText
from gateway.protocol.command_text import parse
from gateway.protocol.framing import (
    EEPROM_DONE,
    Framing,
    Series,
    encode_ack,
    encode_data,
    encode_not_accepted,
    encode_unsolicited,
    framing_switch,
)
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.protocol.replies import encode_reply, wrap_position
from gateway.protocol.reply_values import Contact, Version
from gateway.sim import commands, error_output, stepout  # noqa: F401  (commands: handlers)
from gateway.sim.axis import Axis, AxisEventKind
from gateway.sim.commands.program import start_program
from gateway.sim.dispatch import HANDLERS, Refused
from gateway.sim.eeprom import Eeprom
from gateway.sim.flags import Error, Flags
from gateway.sim.line_out import SILENT, Later, PowerOn, Response
from gateway.sim.memory import POSITION_TABLE_SIZE, Baud, Settings
from gateway.sim.ram_state import Runtime
from gateway.sim.rules import check_rules
from gateway.sim.scene import AxisScene

__all__ = ["Controller", "Later", "Response"]

#: The ROM the simulator claims to be: 1.20 has every feature of the manual (ER 1.19, 0X 1.20).
VERSION = Version("1.20", "07-04-01")


class Controller:
    """One RC-233 on the loop, with its two axes, settings, flags and EEPROM."""

    def __init__(
        self,
        body: str,
        *,
        series: Series = Series.DOLLAR,
        scene: Mapping[int, AxisScene] | None = None,
        eeprom: Eeprom | None = None,
        now: float = 0.0,
        version: Version = VERSION,
    ) -> None:
        self.body = body  # the body-number switch; 'F' = inspection mode (§3-III)
        self.series = series
        self.version = version
        self.eeprom = eeprom if eeprom is not None else Eeprom()
        self._scenes = dict(scene) if scene else {1: AxisScene(), 2: AxisScene()}
        self._power = PowerOn()
        self.ems_pressed = False
        self._boot(now)

    # ------------------------------------------------------------------ power

    def _boot(self, now: float) -> None:
        """Power-on: factory RAM, then what EEPROM holds (§10 AL, DL, IL, GA, ES; §11-2)."""
        image = self.eeprom.image
        self.settings = Settings.from_dw_image(image.dw) if image.dw else Settings()
        self.table = list(image.aw) if image.aw else [0] * POSITION_TABLE_SIZE
        # The machine stays where it is through a power cycle; only the counters start at 0.
        old = getattr(self, "axes", {})
        self.axes = {
            n: Axis(
                replace(self._scenes.get(n, AxisScene()), start=old[n].mechanical(now))
                if n in old
                else self._scenes.get(n, AxisScene())
            )
            for n in (1, 2)
        }
        for n, axis in self.axes.items():
            axis.logic = self.settings.motors[n].logic
        self.flags = Flags()
        self.selected = 1  # F (§16)
        self.baud = Baud(image.es) if image.es is not None else Baud.B9600
        self.rt = Runtime.power_on(image.iw, bool(image.ga))
        if self.rt.autostart and self.rt.program:
            start_program(self, None, now)  # §10 GA, §11-3 4.: the program runs at power-on

    def power_off(self, now: float) -> None:
        """Switch off: no pulses without power, so a moving motor stops where it is."""
        self.advance(now)
        for axis in self.axes.values():
            axis.stop(now)
        self._power.on = False

    def power_cycle(self, now: float) -> Response:
        """Switch off and on again: RAM lost, EEPROM kept; an erase in progress is lost too."""
        self._power = PowerOn()
        self._boot(now)
        return SILENT

    def erase_eeprom(self) -> None:
        """Erase every EEPROM area at once (the body-F '/' procedure of §10 ES)."""
        self.eeprom.erase()

    def inspect(self, data: bytes, now: float) -> bytes:
        """Body switch F (§3-III): echo what is heard; a lone '/' erases the EEPROM (§10 ES)."""
        if data.strip(b"\r") == b"/":
            self.erase_eeprom()
        return data

    # ------------------------------------------------------------------ what the loop reads

    @property
    def framing(self) -> Framing:
        """The controller's framing switches (EE, EL, ER, SUM)."""
        return self.settings.shared.framing

    @property
    def awaiting_program(self) -> bool:
        """True after ``I``: the next bytes up to CR are program text (§10 I)."""
        return self.rt.awaiting_program

    @property
    def position_format(self) -> PositionFormat:
        """How positions are written: mode 1 is always signed (§7-4), else EP."""
        if self.settings.shared.mode == 1:
            return PositionFormat.SIGNED
        return self.settings.shared.positions

    # ------------------------------------------------------------------ the line

    def receive(self, event: CommandFrame | RawText, now: float) -> Response:
        """Act on one frame (or program text) addressed to this controller.

        A running user program first does what it had to do up to ``now``; what it sent comes
        with the response (``later``), ahead of the reply in time.
        """
        if not self._power.on or now < self._power.busy_until:
            return SILENT
        self.run_program(now)
        response = self._receive(event, now)
        self.nudge(now)  # the command may have changed what a waiting program reads
        return Response(response.reply, (*response.later, *self._drain()))

    def _receive(self, event: CommandFrame | RawText, now: float) -> Response:
        self.advance(now)
        if isinstance(event, RawText):
            if not self.rt.take_program_text(event.text):
                self.flags.raise_(Error.COMMAND)  # §10 I: not starting with '/'
                return self._reply_ack(False, event.raw)
            return self._reply_ack(True, event.raw)
        if event.checksum_ok is False:
            return Response(encode_not_accepted())  # §10 SUM: a bad checksum is answered '?'
        try:
            command = parse(event.text, positions=self.position_format)
        except InvalidInputError:
            self.flags.raise_(Error.COMMAND)
            return self._reply_ack(False, event.raw)
        try:
            check_rules(self, command, now)
            if command.form.switches_framing:
                return self._switch_framing(command, event.raw)
            value = HANDLERS[command.key](self, command, now)
        except Refused:
            self.flags.raise_(Error.COMMAND)
            return self._reply_ack(False, event.raw)
        later = self._drain()
        if command.reply_format.has_data:
            data = encode_reply(
                command.reply_format,
                value,  # type: ignore[arg-type]
                signed_positions=self.position_format is PositionFormat.SIGNED,
            )
            reply = encode_data(self.body, data, self.framing, series=self.series, sent=event.raw)
            return Response(reply, later)
        return Response(encode_ack(self.framing, sent=event.raw), later)

    def _reply_ack(self, ok: bool, sent: bytes) -> Response:
        return Response(encode_ack(self.framing, sent=sent, error=not ok))

    def _switch_framing(self, command: Command, sent: bytes) -> Response:
        switch = framing_switch(self.framing, command.wire())
        if switch.refused:  # EE1 with SUM1 on, or SUM1 with EE1 on (§10 EE, §10 SUM)
            self.flags.raise_(Error.COMMAND)
            return Response(encode_ack(self.framing, sent=sent, error=True))
        self.settings.shared.framing = switch.after
        return Response(encode_ack(switch.reply, sent=sent))

    # ------------------------------------------------------------------ the user program

    def program_rules(self, command: Command, now: float) -> None:
        """``Refused`` when a program statement breaks the mode or while-moving rules."""
        check_rules(self, command, now, host=False)

    def run_program(self, now: float) -> None:
        """Let the user program do what it has to do up to ``now`` (chapters 11-12)."""
        machine = self.rt.machine
        if machine is not None and self._power.on:
            machine.run(self, now)

    def wake_at(self) -> float | None:
        """When the user program next acts by itself (None: it waits for the outside)."""
        machine = self.rt.machine
        if machine is None or not self._power.on:
            return None
        return machine.next_time(self)

    def wake(self, now: float) -> tuple[Later, ...]:
        """Run the user program up to ``now``; the messages it sent meanwhile."""
        self.run_program(now)
        return self._drain()

    def nudge(self, now: float) -> None:
        """Something outside changed at ``now``: a program polling in a loop looks again."""
        if self.rt.machine is not None:
            self.rt.machine.nudge(now)

    def emit(self, at: float, data: bytes) -> None:
        """Program output sent at ``at`` (query output, /CO, /CC, /O3, '@'; §11-3, §12)."""
        power = self._power
        power.later.append(Later(at, data, lambda: power is self._power))

    def _drain(self) -> tuple[Later, ...]:
        later = tuple(self._power.later)
        self._power.later.clear()
        return later

    # ------------------------------------------------------------------ helpers for handlers

    def later(
        self, delay: float, message: str, now: float, *, still: Callable[[], bool] | None = None
    ) -> None:
        """Send ``$B#message`` CR ``delay`` seconds from ``now`` (EEPROM done, timer up).

        Nothing is sent if the controller was power-cycled meanwhile, or if ``still`` says no.
        """
        data = encode_unsolicited(self.body, message, self.framing, series=self.series)
        power = self._power

        def wanted() -> bool:
            return power is self._power and (still is None or still())

        power.later.append(Later(now + delay, data, wanted))

    def busy(self, until: float, now: float) -> None:
        """Stay silent until ``until`` and then send ``$B#*`` (EE///, §10 EE///)."""
        self._power.busy_until = until
        self.later(until - now, EEPROM_DONE, now)

    def advance(self, now: float) -> None:
        """Bring both axes to ``now``, latch what stopped them (§10 "", §10 9), let ``K``
        turn its outputs ON for the errors since (§10 K), apply mode, PA and PB to the axes."""
        for axis in self.axes.values():
            for event in axis.advance(now):
                if event.kind is AxisEventKind.LIMIT:
                    self.flags.raise_(Error.LIMIT)
                elif event.kind is AxisEventKind.EMERGENCY:
                    self.flags.raise_(Error.EMERGENCY)
                elif event.kind is AxisEventKind.HOMED:
                    self.flags.step_out = False  # §10 9 ⑤: a completed homing clears step-out
                elif event.kind is AxisEventKind.STEP_OUT:
                    self.step_out_detected()
        setting = self.settings.shared.error_output
        self.rt.outputs = error_output.apply(setting, self.flags.take_rises(), self.rt.outputs)
        self.configure_axes(now)

    def configure_axes(self, now: float) -> None:
        """Mode 1 counts encoder pulses, mode 2 drives a servo (§10 E); PA, PB per motor."""
        mode = self.settings.shared.mode
        for n, axis in self.axes.items():
            axis.configure(now, mode, self.settings.motors[n].pa, self.settings.motors[n].pb)

    def step_out_detected(self) -> None:
        """Latch a step-out: 9 bit 6, and the limit error of both stores (§10 9 bit 1, ⑥)."""
        self.flags.step_out = True
        self.flags.raise_(Error.LIMIT)

    def moving_motor(self, now: float) -> int | None:
        """The motor that is moving, if any (the two never move together, §2)."""
        for n, axis in self.axes.items():
            if axis.is_moving(now):
                return n
        return None

    def motor_of(self, command: Command) -> int:
        """The motor a command acts on; a motor suffix changes the selection (§9-1, §10 F)."""
        motor = command.motor
        if motor is None:
            return self.selected
        if command.form.selects_motor:
            self.selected = motor
        return motor

    def position(self, motor: int, now: float) -> int:
        """The position counter of ``motor`` as the controller reports it (§10 EP, §7-4)."""
        counter = self.axes[motor].counter(now)
        return wrap_position(counter, self.position_format is PositionFormat.SIGNED)

    def shown(self, counter: int) -> int:
        """A stored 24-bit value (A table, position data) in the current position format."""
        return wrap_position(counter, self.position_format is PositionFormat.SIGNED)

    @property
    def ems_on(self) -> bool:
        """The EMS input as the controller reads it: the switch through the EA logic."""
        closed = self.ems_pressed
        return closed != (self.settings.shared.ems_logic is Contact.B)

    def set_ems(self, now: float, pressed: bool) -> None:
        """Press or release the emergency stop: stops the moving axis, latches bit 2."""
        self.advance(now)
        self.ems_pressed = pressed
        if self.ems_on:
            self.flags.raise_(Error.EMERGENCY)
            for axis in self.axes.values():
                axis.emergency(now)

    def force_sensor(self, now: float, motor: int, sensor: str, on: bool | None) -> None:
        """Force one sensor of ``motor`` ON/OFF, or give it back to the scene (None)."""
        self.advance(now)
        self.axes[motor].force(sensor, on)  # type: ignore[arg-type]

    def preset(self, now: float, motor: int, position: int) -> None:
        """An ``R`` the gateway did not send (§10 R): refused while that motor moves."""
        self.advance(now)
        axis = self.axes[motor]
        if axis.is_moving(now):
            raise ValueError(f"motor {motor} moves: R is refused while moving (§10 R)")
        axis.preset(now, position)

    def slip(self, now: float, motor: int, pulses: int) -> None:
        """Lose ``pulses`` on ``motor`` (step-out injection); a motor at rest is checked at
        once when QS 2 asks for it (§10 QS, mode 1), a moving one by its motion's detection."""
        self.advance(now)
        axis = self.axes[motor]
        axis.slip(now, pulses)
        guard = stepout.rest_guard_for(self.settings, motor, self.selected)
        if guard and not axis.is_moving(now) and abs(axis.counts.deviation) > guard.window:
            self.step_out_detected()

    def set_inp(self, now: float, motor: int, on: bool | None) -> None:
        """Give (True) or hold OFF (False) the INP of ``motor``'s servo; None: the driver's own."""
        self.advance(now)
        self.axes[motor].set_inp(now, on)

    def set_input(self, now: float, bit: int, on: bool) -> None:
        """Drive general input ``bit`` (0-7) of the I/O port."""
        self.rt.set_input(bit, on)

    def note_noise(self, now: float) -> None:
        """A frame for this controller was garbled on the line: communication error (9 bit 0)."""
        self.flags.raise_(Error.COMMUNICATION)

    def snapshot(self, now: float) -> dict[str, Any]:
        """A JSON-ready view of the controller for the control surface and tests."""
        self.advance(now)
        return {
            "body": self.body,
            "series": self.series.value,
            "baud": self.baud.bps,
            "mode": self.settings.shared.mode,
            "selected": self.selected,
            "framing": {
                "echo": self.framing.echo,
                "cr_after_ack": self.framing.cr_after_ack,
                "error_mark": self.framing.error_mark,
                "checksum": self.framing.checksum,
            },
            "status_flags": int(self.flags.status),
            "condition_flags": int(self.flags.condition),
            "step_out": self.flags.step_out,
            "ems": self.ems_on,
            "busy": now < self._power.busy_until,
            "axes": {
                str(n): {
                    "position": self.position(n, now),
                    "moving": axis.is_moving(now),
                    "speed": axis.speed(now),
                    "inp": axis.inp(now),
                    "clr_pulses": list(axis.servo.clr),
                }
                for n, axis in self.axes.items()
            },
        }
