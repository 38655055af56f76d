"""What one simulated RC-233 remembers: per-motor and shared settings with the §16 defaults.

RAM holds a ``Settings`` (both motors' ``MotorSettings`` and the ``SharedSettings``); ``DW``
copies the whole of it to EEPROM and ``DL`` (or power-on after a ``DW``) copies it back
(§10 DW, DL; §11-2). The ``A`` table and the user program have their own EEPROM areas (``AW``,
``IW``), the baud rate and the autostart flag are written by ``ES`` and ``GA`` themselves.

Which setting is per motor and which is shared follows §10 F and each command's section; where
the manual is silent (``0X``, ``0Z``, ``ED``, ``K``, ``N``) the value is shared, as
docs/manual-notes.md says.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

from gateway.protocol.framing import BAUD_RATES, Framing
from gateway.protocol.params import PositionFormat
from gateway.protocol.reply_values import (
    Contact,
    ErrorOutput,
    ErrorWatch,
    MotorPair,
    PortByte,
    SensorLogic,
    SpeedPoint,
)
from gateway.protocol.speeds import SpeedSettings

__all__ = [
    "POSITION_TABLE_SIZE",
    "SPEED_POINTS",
    "Baud",
    "MotorSettings",
    "Settings",
    "SharedSettings",
]

#: ``A`` positions 000-999 (§10 A).
POSITION_TABLE_SIZE = 1000
#: ``N`` speed-change points 1-5 (§10 N).
SPEED_POINTS = 5


class Baud(IntEnum):
    """The ``ES`` setting (§10 ES): the digit and the rate it stands for."""

    B9600 = 0
    B1200 = 1
    B300 = 2

    @property
    def bps(self) -> int:
        """Bits per second."""
        return BAUD_RATES[self.value]


@dataclass
class MotorSettings:
    """Settings stored once per motor (§10 F list; §10 0B, 0Q, EA), factory values of §16."""

    search_pulses: int = 20  # 0S
    back_factor: int = 2  # 0B
    step_out_pulses: int = 10  # 0Q{pd}
    oh: int = 5000  # OH: high speed data
    ol: int = 500  # OL: low speed data
    os: int = 300  # OS: acceleration data
    oc: int = 0  # OC: S-curve rate, 0 = trapezoid
    step_out_period: int = 400  # Q{s1}
    pa: int = 1  # PA: encoder multiplication
    pb: int = 10  # PB: pulse/encoder ratio
    # EA bits 1, 2, 3, 5; the EMS bit (4) is shared and lives in SharedSettings (§10 EA).
    logic: SensorLogic = SensorLogic()

    def speed(self, ox: int) -> SpeedSettings:
        """The chapter-7 speed settings of this motor with the shared OX."""
        return SpeedSettings(oh=self.oh, ol=self.ol, os=self.os, oc=self.oc, ox=ox)


def _points() -> list[SpeedPoint]:
    return [SpeedPoint() for _ in range(SPEED_POINTS)]


@dataclass
class SharedSettings:
    """Settings shared by both motors, factory values of §16."""

    ox: int = 300  # OX: speed multiplier data
    mode: int = 0  # E
    positions: PositionFormat = PositionFormat.UNSIGNED  # EP0
    pulse_output: int = 1  # ED: 1 = 2P (CW/CCW pulses), 0 = 1P
    new_homing: bool = False  # 0X1 (mode 2)
    z_count: int = 1  # 0Z{n}
    position_data: int = 0  # 2{pp}
    step_out_window: int = 4  # QE
    adjust: MotorPair = MotorPair()  # QJ
    adjust_time: int = 3  # QJT, 10 ms units
    adjust_limit: int = 800  # QJA
    adjust_speed: int = 0  # QJO, 0 = low speed
    step_out_detect: MotorPair = MotorPair()  # QS
    encoder_step_out: MotorPair = MotorPair()  # QSE
    error_output: ErrorOutput = ErrorOutput()  # K
    ems_logic: Contact = Contact.A  # EA bit 4, common to both motors
    framing: Framing = Framing()  # EE, EL, ER, SUM
    points: list[SpeedPoint] = field(default_factory=_points)  # N1-N5 (not stored by DW)
    points_on: bool = False  # NS / NC (§16: N off)


@dataclass
class Settings:
    """Everything ``DW`` stores, plus the RAM-only settings next to it."""

    motors: dict[int, MotorSettings] = field(
        default_factory=lambda: {1: MotorSettings(), 2: MotorSettings()}
    )
    shared: SharedSettings = field(default_factory=SharedSettings)

    def logic(self, motor: int) -> SensorLogic:
        """The EA logic of one motor as ``EA`` reports it: its own bits and the shared EMS bit."""
        return dataclasses.replace(self.motors[motor].logic, emergency_stop=self.shared.ems_logic)

    def speed(self, motor: int) -> SpeedSettings:
        """The chapter-7 speed settings of one motor."""
        return self.motors[motor].speed(self.shared.ox)

    # ------------------------------------------------------------------ EEPROM image (DW)

    def dw_image(self) -> dict[str, Any]:
        """The DW area as JSON-ready data: every value §10 DW lists, nothing RAM-only."""
        shared = self.shared
        return {
            "motors": {
                str(n): {
                    "search_pulses": m.search_pulses,
                    "back_factor": m.back_factor,
                    "step_out_pulses": m.step_out_pulses,
                    "oh": m.oh,
                    "ol": m.ol,
                    "os": m.os,
                    "oc": m.oc,
                    "step_out_period": m.step_out_period,
                    "pa": m.pa,
                    "pb": m.pb,
                    "logic": m.logic.byte,
                }
                for n, m in self.motors.items()
            },
            "ox": shared.ox,
            "mode": shared.mode,
            "positions": shared.positions.value,
            "pulse_output": shared.pulse_output,
            "new_homing": shared.new_homing,
            "z_count": shared.z_count,
            "position_data": shared.position_data,
            "step_out_window": shared.step_out_window,
            "adjust": [shared.adjust.motor1, shared.adjust.motor2],
            "adjust_time": shared.adjust_time,
            "adjust_limit": shared.adjust_limit,
            "adjust_speed": shared.adjust_speed,
            "step_out_detect": [shared.step_out_detect.motor1, shared.step_out_detect.motor2],
            "error_output": [int(shared.error_output.watch), shared.error_output.outputs.value],
            "ems_logic": int(shared.ems_logic),
            "framing": dataclasses.asdict(shared.framing),
        }

    @classmethod
    def from_dw_image(cls, image: dict[str, Any]) -> Settings:
        """Settings as ``DL`` loads them from a DW image; RAM-only values take their defaults."""
        settings = cls()
        for key, values in image["motors"].items():
            motor = settings.motors[int(key)]
            for name, value in values.items():
                if name == "logic":
                    motor.logic = SensorLogic.from_byte(value)
                else:
                    setattr(motor, name, int(value))
        shared = settings.shared
        shared.ox = image["ox"]
        shared.mode = image["mode"]
        shared.positions = PositionFormat(image["positions"])
        shared.pulse_output = image["pulse_output"]
        shared.new_homing = bool(image["new_homing"])
        shared.z_count = image["z_count"]
        shared.position_data = image["position_data"]
        shared.step_out_window = image["step_out_window"]
        shared.adjust = MotorPair(*image["adjust"])
        shared.adjust_time = image["adjust_time"]
        shared.adjust_limit = image["adjust_limit"]
        shared.adjust_speed = image["adjust_speed"]
        shared.step_out_detect = MotorPair(*image["step_out_detect"])
        watch, outputs = image["error_output"]
        shared.error_output = ErrorOutput(ErrorWatch(watch), PortByte(outputs))
        shared.ems_logic = Contact(image["ems_logic"])
        shared.framing = Framing(**image["framing"])
        return settings
