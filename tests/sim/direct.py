"""A test harness that talks to simulated controllers without the loop's wire timing.

It cuts bytes into frames with the same ``CommandReader`` the loop uses and hands them to the
addressed controller at an explicit simulated time, so a test can check replies, flags and
state changes of the controller itself, step by step. Timing and faults are the loop's tests.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from gateway.protocol.command_reader import CommandFrame, CommandReader, RawText
from gateway.protocol.framing import Series, to_wire
from gateway.sim.controller import Controller
from gateway.sim.eeprom import Eeprom
from gateway.sim.line_out import Later


@dataclass
class Direct:
    """Controllers by body number, a reader, a clock the test moves, and what was sent later."""

    bodies: str = "1"
    eeprom_dir: Path | None = None
    now: float = 0.0
    controllers: dict[str, Controller] = field(init=False)
    reader: CommandReader = field(init=False, default_factory=CommandReader)
    later: list[Later] = field(init=False, default_factory=list)

    def __post_init__(self) -> None:
        self.controllers = {
            body: Controller(body, eeprom=Eeprom.for_body(self.eeprom_dir, "$", body), now=self.now)
            for body in self.bodies
        }
        for ctl in self.controllers.values():
            self._sync(ctl)

    def _sync(self, ctl: Controller) -> None:
        """Tell the reader what the controller's framing means for the next bytes."""
        self.reader.set_checksum(ctl.body, ctl.framing.checksum, series=Series.DOLLAR)
        if ctl.awaiting_program:
            self.reader.begin_raw(ctl.body)

    def __getitem__(self, body: str) -> Controller:
        return self.controllers[body]

    def send(self, data: bytes, *, at: float | None = None) -> bytes:
        """Send host bytes (one or more frames); return every reply byte, in order."""
        if at is not None:
            self.now = at
        out = b""
        self.reader.push(data)
        while (event := self.reader.next_event()) is not None:
            if not isinstance(event, CommandFrame | RawText):
                continue
            ctl = self.controllers.get(event.body)
            if ctl is None:
                continue
            response = ctl.receive(event, self.now)
            out += response.reply
            self.later.extend(response.later)
            self._sync(ctl)
        return out

    def cmd(self, text: str, body: str = "1", *, at: float | None = None) -> bytes:
        """Send ``$`` body text CR (no checksum) and return the reply."""
        return self.send(b"$" + to_wire(body + text) + b"\r", at=at)

    def advance(self, seconds: float) -> None:
        """Move the simulated clock on."""
        self.now += seconds

    def due(self) -> list[bytes]:
        """The unsolicited messages due by now that are still wanted, oldest first."""
        ready = sorted((m for m in self.later if m.at <= self.now + 1e-9), key=lambda m: m.at)
        self.later = [m for m in self.later if m.at > self.now + 1e-9]
        return [m.data for m in ready if m.wanted()]

    def power_cycle(self, body: str = "1") -> None:
        """Switch one controller off and on (EEPROM kept)."""
        self.controllers[body].power_cycle(self.now)
        self._sync(self.controllers[body])

    def run(self, until: float, body: str = "1") -> list[bytes]:
        """Let the user program of ``body`` run up to ``until``; the messages due by then.

        The program is woken at the times it asks for (``Controller.wake_at``), as the loop
        does; the clock ends at ``until``.
        """
        ctl = self.controllers[body]
        while (t := ctl.wake_at()) is not None and t <= until:
            self.now = max(self.now, t)
            self.later.extend(ctl.wake(self.now))
        self.now = max(self.now, until)
        return self.due()

    def set_input(self, bit: int, on: bool, body: str = "1") -> None:
        """Drive a general input (or INP1/INP2 as 8/9) now, as the control surface does."""
        ctl = self.controllers[body]
        ctl.set_input(self.now, bit, on)
        ctl.nudge(self.now)

    def upload(self, program: str, body: str = "1") -> bytes:
        """``I`` then the program text and CR (§10 I); the two replies."""
        return self.cmd("I", body) + self.send(to_wire(program) + b"\r")
