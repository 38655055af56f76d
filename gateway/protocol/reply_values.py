"""Typed values of the RC-233's query replies, one type per reply shape (§9-2, §10).

These are plain immutable values: ``replies`` turns reply text into them and back. Each type
checks its own ranges on construction (``ValueError``), so a value that exists can always be
written as a reply; the bit numbers are the manual's tables, quoted where they are used.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from enum import IntEnum, IntFlag, StrEnum
from typing import ClassVar

from gateway.protocol.params import UNSIGNED_MAX

__all__ = [
    "ClrState",
    "ConditionFlags",
    "Contact",
    "ErrorOutput",
    "ErrorWatch",
    "InputsWithInp",
    "MotorPair",
    "OutputsWithClr",
    "PortByte",
    "ProgramState",
    "SensorBits",
    "SensorLogic",
    "SpeedPoint",
    "StatusFlags",
    "Version",
]


def _bit(value: int, n: int) -> bool:
    return bool(value >> n & 1)


def _check_byte(value: int, what: str) -> None:
    if not 0 <= value <= 0xFF:
        raise ValueError(f"{what} must be 0-255 (one byte), got {value}")


@dataclass(frozen=True)
class PortByte:
    """Eight on/off bits, bit 7 to bit 0 as two hex digits DU DL.

    Used for the general input port (``C``), the general output port (``CO``), the output
    mask of ``K`` and a user-program data buffer (``GR{bf}``); 1 = ON (§10 C, CO, D, GR).
    """

    value: int = 0

    def __post_init__(self) -> None:
        _check_byte(self.value, "a port byte")

    @classmethod
    def of(cls, *bits: int) -> PortByte:
        """The byte with exactly the given bit numbers (0-7) ON."""
        value = 0
        for n in bits:
            if not 0 <= n <= 7:
                raise ValueError(f"bit numbers are 0-7, got {n}")
            value |= 1 << n
        return cls(value)

    def __getitem__(self, n: int) -> bool:
        """Whether bit ``n`` (0-7) is ON."""
        if not 0 <= n <= 7:
            raise IndexError(f"bit numbers are 0-7, got {n}")
        return _bit(self.value, n)

    @property
    def on(self) -> frozenset[int]:
        """The bit numbers that are ON."""
        return frozenset(n for n in range(8) if _bit(self.value, n))

    def with_bit(self, n: int, on: bool) -> PortByte:
        """A copy with bit ``n`` set ON or OFF (what ``D{bit}{value}B`` does to the outputs)."""
        if not 0 <= n <= 7:
            raise ValueError(f"bit numbers are 0-7, got {n}")
        return PortByte(self.value | 1 << n if on else self.value & ~(1 << n))


@dataclass(frozen=True)
class StatusFlags:
    """The status flags of ``""`` (§10 ""): one hex digit, bit 0 to bit 3."""

    moving: bool = False  # bit 0: live, never latched
    limit_error: bool = False  # bit 1: latched until the next "" read
    emergency_stop: bool = False  # bit 2: latched
    command_error: bool = False  # bit 3: latched

    @classmethod
    def from_nibble(cls, value: int) -> StatusFlags:
        """The flags of a 4-bit value (0-15)."""
        if not 0 <= value <= 0xF:
            raise ValueError(f"status flags are 4 bits (0-15), got {value}")
        return cls(_bit(value, 0), _bit(value, 1), _bit(value, 2), _bit(value, 3))

    @property
    def nibble(self) -> int:
        """The flags as the 4-bit value the reply's hex digit shows."""
        bits = (self.moving, self.limit_error, self.emergency_stop, self.command_error)
        return sum(int(b) << n for n, b in enumerate(bits))

    @property
    def has_error(self) -> bool:
        """True when any latched error bit (1-3) is set."""
        return self.limit_error or self.emergency_stop or self.command_error


@dataclass(frozen=True)
class ConditionFlags:
    """The condition flags of ``9`` form I (§10 9): two hex digits, bit 7 to bit 0.

    Bits 0-3 are cleared by the form-I read, bit 6 only by homing, ``RD`` or ``/EC``.
    """

    communication_error: bool = False  # bit 0: noise error or receive overflow
    limit_error: bool = False  # bit 1
    emergency_stop: bool = False  # bit 2
    command_error: bool = False  # bit 3
    mode: int = 0  # bits 5,4: 00 mode 0, 01 mode 1, 10 mode 2, 11 unused
    step_out: bool = False  # bit 6
    selected_motor: int = 1  # bit 7: 0 = motor 1, 1 = motor 2

    def __post_init__(self) -> None:
        if self.mode not in (0, 1, 2):
            raise ValueError(f"mode must be 0-2 (bits 5,4 = 11 are unused), got {self.mode}")
        if self.selected_motor not in (1, 2):
            raise ValueError(f"selected_motor must be 1 or 2, got {self.selected_motor}")

    @classmethod
    def from_byte(cls, value: int) -> ConditionFlags:
        """The flags of an 8-bit value; mode bits 11 raise ``ValueError``."""
        _check_byte(value, "condition flags")
        return cls(
            communication_error=_bit(value, 0),
            limit_error=_bit(value, 1),
            emergency_stop=_bit(value, 2),
            command_error=_bit(value, 3),
            mode=value >> 4 & 0b11,
            step_out=_bit(value, 6),
            selected_motor=2 if _bit(value, 7) else 1,
        )

    @property
    def byte(self) -> int:
        """The flags as the 8-bit value the reply's two hex digits show."""
        low = (self.communication_error, self.limit_error, self.emergency_stop, self.command_error)
        return (
            sum(int(b) << n for n, b in enumerate(low))
            | self.mode << 4
            | int(self.step_out) << 6
            | (self.selected_motor - 1) << 7
        )


@dataclass(frozen=True)
class InputsWithInp:
    """``CA`` (§10 C form III): IP (bit 0 = INP1, bit 1 = INP2), then the input port."""

    inp1: bool = False
    inp2: bool = False
    inputs: PortByte = PortByte()


@dataclass(frozen=True)
class OutputsWithClr:
    """``COA`` (§10 CO form II): DC (bit 0 = CLR1, bit 1 = CLR2), then the output port."""

    clr1: bool = False
    clr2: bool = False
    outputs: PortByte = PortByte()


@dataclass(frozen=True)
class SensorBits:
    """The sensor inputs of one motor, ``CL`` / ``CLM{mt}`` (§10 CL bit table).

    DL: bit 0 CWLS, bit 1 CCWLS, bits 2-3 unused (always 0); DU: bit 4 ORG, bit 5 EMS,
    bit 6 step-out detection sensor (EZ), bit 7 unused (always 0). 1 = ON.
    """

    UNUSED: ClassVar[int] = 0b1000_1100

    cw_limit: bool = False  # bit 0, CWLS
    ccw_limit: bool = False  # bit 1, CCWLS
    org: bool = False  # bit 4, ORG sensor
    emergency_stop: bool = False  # bit 5, EMS signal
    step_out_sensor: bool = False  # bit 6, EZ input

    @classmethod
    def from_byte(cls, value: int) -> SensorBits:
        """The sensors of an 8-bit value; a set unused bit (2, 3, 7) raises ``ValueError``."""
        _check_byte(value, "sensor bits")
        if value & cls.UNUSED:
            unused = sorted(n for n in range(8) if _bit(value & cls.UNUSED, n))
            raise ValueError(f"unused sensor bit(s) {unused} set (the manual: always 0)")
        return cls(_bit(value, 0), _bit(value, 1), _bit(value, 4), _bit(value, 5), _bit(value, 6))

    @property
    def byte(self) -> int:
        """The sensors as the 8-bit value of the reply."""
        return (
            int(self.cw_limit)
            | int(self.ccw_limit) << 1
            | int(self.org) << 4
            | int(self.emergency_stop) << 5
            | int(self.step_out_sensor) << 6
        )


class Contact(IntEnum):
    """Input logic of one sensor (§10 EA): A = normally open (bit 0), B = normally closed (1)."""

    A = 0
    B = 1


@dataclass(frozen=True)
class SensorLogic:
    """The sensor input logic of ``EA`` (§10 EA bit-number table).

    Bit 0 unused, bit 1 EZ (step-out sensor / encoder Z), bit 2 limit sensors (CW and CCW
    together), bit 3 ORG, bit 4 EMS, bit 5 INP, bits 6-7 unused; unused bits read 0.
    """

    UNUSED: ClassVar[int] = 0b1100_0001

    step_out_sensor: Contact = Contact.A  # bit 1, EZ
    limit: Contact = Contact.A  # bit 2, CWLS and CCWLS
    org: Contact = Contact.A  # bit 3
    emergency_stop: Contact = Contact.A  # bit 4, common to both motors
    inp: Contact = Contact.A  # bit 5

    @classmethod
    def from_byte(cls, value: int) -> SensorLogic:
        """The logic of an 8-bit value; a set unused bit (0, 6, 7) raises ``ValueError``."""
        _check_byte(value, "sensor logic")
        if value & cls.UNUSED:
            unused = sorted(n for n in range(8) if _bit(value & cls.UNUSED, n))
            raise ValueError(f"unused sensor-logic bit(s) {unused} set (the manual: always 0)")
        return cls(*(Contact(value >> n & 1) for n in range(1, 6)))

    @property
    def byte(self) -> int:
        """The logic as the 8-bit value of the reply."""
        fields = (self.step_out_sensor, self.limit, self.org, self.emergency_stop, self.inp)
        return sum(int(c) << n for n, c in enumerate(fields, start=1))


@dataclass(frozen=True)
class ClrState:
    """``DS`` (§10 DS form III): the CLR outputs; the reply writes CLR2 first."""

    clr1: bool = False
    clr2: bool = False


@dataclass(frozen=True)
class MotorPair:
    """``QS``, ``QJ``, ``QSE``: one setting digit per motor; the reply writes motor 2 first.

    ``QS`` allows 0-2 (2 = detect also at rest, mode 1, Ver 1.09+); ``QJ``/``QSE`` 0-1.
    """

    motor1: int = 0
    motor2: int = 0

    def __post_init__(self) -> None:
        for name, v in (("motor1", self.motor1), ("motor2", self.motor2)):
            if v not in (0, 1, 2):
                raise ValueError(f"{name} must be 0, 1 or 2, got {v}")


class ErrorWatch(IntFlag):
    """The errors ``K`` watches (§10 K, DT table): 1 limit, 2 EMS, 4 step-out."""

    NONE = 0
    LIMIT = 1
    EMERGENCY_STOP = 2
    STEP_OUT = 4


@dataclass(frozen=True)
class ErrorOutput:
    """The error-output setting of ``K`` (§10 K form V): ``DT,DUDL``; DT 0 = off."""

    watch: ErrorWatch = ErrorWatch.NONE
    outputs: PortByte = PortByte()  # the output bits turned ON when a watched error occurs

    def __post_init__(self) -> None:
        # IntFlag keeps unknown bits (ErrorWatch(8) exists), so the DT range is checked here.
        if not 0 <= int(self.watch) <= 7:
            raise ValueError(f"watch (DT) must be 0-7, got {int(self.watch)}")

    @property
    def enabled(self) -> bool:
        """False after ``K0`` (DT = 0): the function is off."""
        return self.watch != ErrorWatch.NONE


#: Upper bounds of a speed-change point (§10 N form I): sp up to 16,383, pj up to 16,777,215.
SPEED_MAX = 16_383
REMAINING_MAX = UNSIGNED_MAX


@dataclass(frozen=True)
class SpeedPoint:
    """One speed-change point of ``N{pn}`` (§10 N form VI): speed data and remaining pulses."""

    speed: int = 0  # sp: the speed data after the change
    remaining: int = 0  # pj: pulses left to the target when the change starts

    def __post_init__(self) -> None:
        if not 0 <= self.speed <= SPEED_MAX:
            raise ValueError(f"speed (sp) must be 0-{SPEED_MAX}, got {self.speed}")
        if not 0 <= self.remaining <= REMAINING_MAX:
            raise ValueError(f"remaining (pj) must be 0-{REMAINING_MAX}, got {self.remaining}")


class ProgramState(StrEnum):
    """The user-program state of ``GSS`` (§10 GSS); reading ERROR clears it to ENDED."""

    RUNNING = "1"
    ENDED = "0"
    PAUSED = "P"  # paused by GS, resumable with GC
    ERROR = "E"  # ended by a command error inside the program


_VERSION_RE = re.compile(r"[0-9]\.[0-9]{2}")
# The manual prints the stamp as '××-××-××' without saying what it is (a date, presumably);
# letters are allowed so that a ROM with a letter in it still reads (docs/manual-notes.md,
# "Replies").
_STAMP_RE = re.compile(r"[0-9A-Za-z]{2}-[0-9A-Za-z]{2}-[0-9A-Za-z]{2}")


@dataclass(frozen=True)
class Version:
    """The ROM version of ``V`` (§10 V): ``RC-233 Ver x.xx by RORZE (xx-xx-xx)``.

    Features depend on it: lower-case labels need 1.18, ``ER`` and ``QJA``/``QJO`` 1.19,
    ``0X`` 1.20; ``QS`` setting 2 needs 1.09.
    """

    version: str  # 'x.xx', e.g. '1.19'
    stamp: str  # the 'xx-xx-xx' in parentheses

    def __post_init__(self) -> None:
        if not _VERSION_RE.fullmatch(self.version):
            raise ValueError(f"version must be 'x.xx' (e.g. '1.19'), got {self.version!r}")
        if not _STAMP_RE.fullmatch(self.stamp):
            raise ValueError(f"stamp must be 'xx-xx-xx' (letters or digits), got {self.stamp!r}")

    @property
    def number(self) -> tuple[int, int]:
        """The version as (major, minor): '1.19' -> (1, 19); compares in release order."""
        major, minor = self.version.split(".")
        return int(major), int(minor)

    def at_least(self, version: str) -> bool:
        """True when this ROM is ``version`` ('x.xx') or newer."""
        if not _VERSION_RE.fullmatch(version):
            raise ValueError(f"version must be 'x.xx' (e.g. '1.19'), got {version!r}")
        major, minor = version.split(".")
        return self.number >= (int(major), int(minor))

    @property
    def has_lowercase_labels(self) -> bool:
        """Lower-case a-z as user-program labels (§11, Ver 1.18+)."""
        return self.at_least("1.18")

    @property
    def has_error_display(self) -> bool:
        """``ER``: the '>@' reply to a command error (§10 ER, Ver 1.19+)."""
        return self.at_least("1.19")

    @property
    def has_adjust_limits(self) -> bool:
        """``QJA`` and ``QJO``, QJ forms VI-IX (§10 QJ, Ver 1.19+)."""
        return self.at_least("1.19")

    @property
    def has_homing_algorithm(self) -> bool:
        """``0X``: the mode-2 homing algorithm choice (§10 0X, Ver 1.20+)."""
        return self.at_least("1.20")

    @property
    def has_step_out_at_rest(self) -> bool:
        """``QS`` setting 2: step-out detection also while stopped (§10 QS, Ver 1.09+)."""
        return self.at_least("1.09")
