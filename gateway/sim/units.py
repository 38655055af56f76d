"""What the simulated line connects: the controllers (as the loop sees them) and their messages.

A ``Unit`` is one controller on the loop: the ``Device`` itself (``controller.Controller``
fulfils the protocol), the body number it was started as, its body switch and its power. A unit
whose body switch read 'F' at power-on is in inspection mode (§3-III) and talks at 9600 (§10 ES
注意点). A ``Message`` is what a unit puts on the return line; it belongs to the power-on it was
made in, and a power-off loses it.

A controller whose user program runs acts without a host frame: the loop asks it when it next
needs to run (``Device.wake_at``), wakes it then (``Device.wake``) and sends what it returns,
and tells it when something outside changed (``Device.nudge``: a control action, a fault).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from gateway.protocol.command_reader import CommandFrame, RawText
from gateway.protocol.framing import Framing, Series
from gateway.sim.clock import RecordKind
from gateway.sim.faults import Draw
from gateway.sim.memory import Baud

__all__ = [
    "INSPECTION",
    "INSPECTION_BAUD",
    "Device",
    "LaterLike",
    "Message",
    "ResponseLike",
    "Unit",
]

#: The body switch position of the inspection mode (§3-III).
INSPECTION = "F"
#: The rate of a controller in inspection mode (§10 ES 注意点: the host is set to 9600 for it).
INSPECTION_BAUD = 9600


class LaterLike(Protocol):
    """An unsolicited message (``line_out.Later``)."""

    @property
    def at(self) -> float:
        """Simulated time the controller sends it."""

    @property
    def data(self) -> bytes:
        """The bytes."""

    def wanted(self) -> bool:
        """False when the message was called off meanwhile (asked at ``at``)."""


class ResponseLike(Protocol):
    """What a controller answers to a frame (``line_out.Response``)."""

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

    def wake_at(self) -> float | None:
        """When its user program next acts by itself (None: not by itself)."""

    def wake(self, now: float) -> Sequence[LaterLike]:
        """Run its user program up to ``now``; the messages it sent meanwhile."""

    def nudge(self, now: float) -> None:
        """Something outside changed at ``now`` (an input, a sensor, EMS)."""

    def note_noise(self, now: float) -> None:
        """A frame reached it garbled (communication error)."""

    def power_off(self, now: float) -> None:
        """Power lost: pulse output stops at once."""

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

    def preset(self, now: float, motor: int, position: int) -> None:
        """Set a motor's counter without motion, from outside the line (a foreign ``R``)."""

    def set_input(self, now: float, bit: int, on: bool) -> None:
        """Drive a general input."""

    def snapshot(self, now: float) -> dict[str, Any]:
        """JSON-ready state."""


@dataclass
class Unit:
    """One controller on the loop: its name, power and body switch."""

    device: Device
    name: str  # the body number it was given at start; stays when the switch is turned
    switch: str  # the body switch; read at the next power-on
    on: bool = True
    generation: int = 0  # counts power-offs: a message of an older generation is lost
    wake_token: int = 0  # the program wake armed last; older ones are stale
    wake_time: float | None = None  # when that wake is due

    @property
    def inspecting(self) -> bool:
        """Body switch F at power-on: inspection mode (§3-III)."""
        return self.device.body == INSPECTION

    @property
    def bps(self) -> int:
        """The rate it talks at."""
        return INSPECTION_BAUD if self.inspecting else self.device.baud.bps


@dataclass(frozen=True)
class Message:
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
