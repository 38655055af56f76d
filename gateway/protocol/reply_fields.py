"""The data field of each query reply, one parser and writer per shape (§9-2, §10 replies).

A parser takes the data text (framing and checksum removed) and returns the value or raises
``ValueError`` naming the rule it broke; ``replies`` wraps that into ``ReplyFormatError`` and
pairs each parser with its writer by ``ReplyFormat``. Positions have their own helpers because
the controller writes them in two views (EP0 unsigned, EP1 or mode 1 signed, §10 EP).
"""

from __future__ import annotations

import re
from collections.abc import Callable

from gateway.protocol.params import POSITION_MIN, SIGNED_MAX, UNSIGNED_MAX
from gateway.protocol.program import CAPACITY_BYTES
from gateway.protocol.reply_values import (
    ClrState,
    ConditionFlags,
    ErrorOutput,
    ErrorWatch,
    InputsWithInp,
    MotorPair,
    OutputsWithClr,
    PortByte,
    ProgramState,
    SensorBits,
    SensorLogic,
    SpeedPoint,
    StatusFlags,
    Version,
)

__all__ = [
    "check_int",
    "encode_position",
    "match_rule",
    "parse_byte",
    "parse_clr_state",
    "parse_condition",
    "parse_condition_bit",
    "parse_decimal",
    "parse_error_output",
    "parse_flagged_byte",
    "parse_inputs_inp",
    "parse_motor_pair",
    "parse_outputs_clr",
    "parse_position",
    "parse_program_state",
    "parse_program_text",
    "parse_sensor_logic",
    "parse_sensors",
    "parse_speed_point",
    "parse_status",
    "parse_version",
    "show_decimal",
    "show_program_text",
    "wrap_position",
]

_HEX1 = re.compile(r"[0-9A-F]")
_HEX2 = re.compile(r"[0-9A-F]{2}")
_HEX3 = re.compile(r"([0-9A-F])([0-9A-F]{2})")
_UNSIGNED = re.compile(r"[0-9]{8}")
_SIGNED = re.compile(r"[+-][0-9]{7}")
_DECIMAL = {n: re.compile(rf"[0-9]{{{n}}}") for n in (1, 3, 5)}
_PAIR01 = re.compile(r"[01]{2}")
_PAIR02 = re.compile(r"[0-2]{2}")
_ERROR_OUTPUT = re.compile(r"([0-9A-F]),([0-9A-F]{2})")
_SPEED_POINT = re.compile(r"([0-9]{5}),([0-9]{8})")
_VERSION = re.compile(
    r"RC-233 Ver ([0-9]\.[0-9]{2}) by RORZE "
    r"\(([0-9A-Za-z]{2}-[0-9A-Za-z]{2}-[0-9A-Za-z]{2})\)"
)
_SIGNED_RULE = "a sign and 7 digits (signed management: EP1 or mode 1)"
_UNSIGNED_RULE = "8 digits (unsigned management: EP0)"


def match_rule(pattern: re.Pattern[str], data: str, rule: str) -> re.Match[str]:
    """The match of ``data`` against ``pattern``; ValueError naming ``rule`` otherwise."""
    m = pattern.fullmatch(data)
    if m is None:
        raise ValueError(f"expected {rule}")
    return m


# --- parsers (text -> value; ValueError on a rule) and writers (value -> text) -------------


def parse_status(data: str) -> StatusFlags:
    """``""``: one hex digit of status flags."""
    match_rule(_HEX1, data, "one upper-case hex digit")
    return StatusFlags.from_nibble(int(data, 16))


def parse_condition(data: str) -> ConditionFlags:
    """``9``: two hex digits of condition flags."""
    match_rule(_HEX2, data, "two upper-case hex digits DU DL")
    return ConditionFlags.from_byte(int(data, 16))


def parse_condition_bit(data: str, bit: int | None) -> int:
    """``9{bit}``: 0/1, or the mode 0-2 for bits 4 and 5."""
    match_rule(_DECIMAL[1], data, "one decimal digit")
    # Bits 4 and 5 answer the mode number (0-2); the other bits 0 or 1 (§10 9 form II).
    top = 2 if bit in (None, 4, 5) else 1
    if int(data) > top:
        which = "a condition bit" if bit is None else f"condition bit {bit}"
        raise ValueError(f"{which} reads 0-{top}")
    return int(data)


def parse_position(data: str, signed: bool | None) -> int:
    """A position in either view; ``signed`` None accepts both."""
    if _UNSIGNED.fullmatch(data):
        if signed is True:
            raise ValueError(f"expected {_SIGNED_RULE}, got 8 digits")
        if int(data) > UNSIGNED_MAX:
            raise ValueError(f"unsigned positions end at {UNSIGNED_MAX}")
    elif _SIGNED.fullmatch(data):
        if signed is False:
            raise ValueError(f"expected {_UNSIGNED_RULE}, got a sign")
        if data == "-0000000":  # the 24-bit counter has one zero, written '+0000000'
            raise ValueError("zero is written '+0000000'")
        if not POSITION_MIN <= int(data) <= SIGNED_MAX:
            raise ValueError(f"signed positions are {POSITION_MIN}..+{SIGNED_MAX}")
    else:
        raise ValueError(f"expected {_UNSIGNED_RULE} or {_SIGNED_RULE}")
    return int(data)


def parse_decimal(width: int) -> Callable[[str], int]:
    """A parser of exactly ``width`` decimal digits."""

    def parse(data: str) -> int:
        match_rule(_DECIMAL[width], data, "one decimal digit" if width == 1 else f"{width} digits")
        return int(data)

    return parse


def parse_byte(data: str) -> PortByte:
    """Two hex digits DU DL: one port byte."""
    match_rule(_HEX2, data, "two upper-case hex digits DU DL")
    return PortByte(int(data, 16))


def parse_flagged_byte(data: str, name: str) -> tuple[bool, bool, PortByte]:
    """Three hex digits: two flag bits named ``name``, then a port byte."""
    m = match_rule(_HEX3, data, f"three upper-case hex digits {name} DU DL")
    pair = int(m[1], 16)
    if pair > 3:  # two bits only: bit 0 = INP1/CLR1, bit 1 = INP2/CLR2
        raise ValueError(f"{name} must be 0-3, got {m[1]}")
    return bool(pair & 1), bool(pair & 2), PortByte(int(m[2], 16))


def parse_inputs_inp(data: str) -> InputsWithInp:
    """``CA``: INP1/INP2, then the general inputs."""
    return InputsWithInp(*parse_flagged_byte(data, "IP"))


def parse_outputs_clr(data: str) -> OutputsWithClr:
    """``COA``: CLR1/CLR2, then the general outputs."""
    return OutputsWithClr(*parse_flagged_byte(data, "DC"))


def parse_sensors(data: str) -> SensorBits:
    """``CL``, ``CLM{mt}``: the sensor bits of one motor."""
    match_rule(_HEX2, data, "two upper-case hex digits DU DL")
    return SensorBits.from_byte(int(data, 16))


def parse_sensor_logic(data: str) -> SensorLogic:
    """``EA``: the A/B contact logic byte."""
    match_rule(_HEX2, data, "two upper-case hex digits DU DL")
    return SensorLogic.from_byte(int(data, 16))


def parse_clr_state(data: str) -> ClrState:
    """``DS``: CLR2 then CLR1, one digit each."""
    match_rule(_PAIR01, data, "two digits 0/1: CLR2 then CLR1")
    return ClrState(clr1=data[1] == "1", clr2=data[0] == "1")


def parse_motor_pair(data: str, max_setting: int) -> MotorPair:
    """``QS``, ``QJ``, ``QSE``: motor 2 then motor 1, each 0..``max_setting``."""
    match_rule(_PAIR02, data, "two digits 0-2: motor 2 then motor 1")
    pair = MotorPair(motor1=int(data[1]), motor2=int(data[0]))
    if max(pair.motor1, pair.motor2) > max_setting:
        raise ValueError(f"settings are 0-{max_setting} for this command")
    return pair


def parse_error_output(data: str) -> ErrorOutput:
    """``K``: DT ',' DU DL."""
    m = match_rule(_ERROR_OUTPUT, data, "DT ',' DU DL (upper-case hex, e.g. '0,00')")
    return ErrorOutput(ErrorWatch(int(m[1], 16)), PortByte(int(m[2], 16)))


def parse_speed_point(data: str) -> SpeedPoint:
    """``N{PN}``: 5 digits ',' 8 digits."""
    m = match_rule(_SPEED_POINT, data, "5 digits ',' 8 digits (sp,pj)")
    return SpeedPoint(int(m[1]), int(m[2]))


def parse_program_state(data: str) -> ProgramState:
    """``GSS``: 1, 0, P or E."""
    try:
        return ProgramState(data)
    except ValueError:
        raise ValueError("expected one of 1, 0, P, E") from None


def parse_program_text(data: str) -> str:
    """``IR``: the stored program text, within the capacity."""
    # Empty means no program in RAM; the manual does not show that reply
    # (docs/manual-notes.md, "`IR` reply").
    if data and not data.startswith("/"):
        raise ValueError("a user program starts with '/'")
    if any(c in "$\r\n" for c in data):  # '$' starts a command, CR ends the frame (§10 I)
        raise ValueError("a user program holds no '$', CR or LF")
    if len(data) > CAPACITY_BYTES:
        raise ValueError(f"a user program is at most {CAPACITY_BYTES} characters, got {len(data)}")
    return data


def parse_version(data: str) -> Version:
    """``V``: the version line."""
    m = match_rule(_VERSION, data, "'RC-233 Ver x.xx by RORZE (xx-xx-xx)' (35 characters)")
    return Version(m[1], m[2])


def check_int(value: int, lo: int, hi: int, what: str) -> int:
    """``value`` when within ``lo..hi``; ValueError naming ``what`` otherwise."""
    if not lo <= value <= hi:
        raise ValueError(f"{what} must be {lo}..{hi}, got {value}")
    return value


def show_decimal(width: int) -> Callable[[int], str]:
    """A writer of exactly ``width`` decimal digits."""

    def show(value: int) -> str:
        return f"{check_int(value, 0, 10**width - 1, f'a {width}-digit value'):0{width}d}"

    return show


def show_program_text(value: str) -> str:
    """The program text as the controller sends it (the parser's rules bind it)."""
    return parse_program_text(value)  # the same rules bind what the simulator may send


def wrap_position(counter: int, signed: bool) -> int:
    """The 24-bit position counter as the controller reports it (§10 EP, §7-4).

    ``counter`` may be any integer (a move past the range wraps): unsigned gives
    0..16,777,215 (-2000 reads 16,775,216), signed -8,388,608..+8,388,607.
    """
    value = counter % (UNSIGNED_MAX + 1)
    return value - (UNSIGNED_MAX + 1) if signed and value > SIGNED_MAX else value


def encode_position(value: int, *, signed: bool) -> str:
    """A position as 8 digits (EP0) or sign + 7 digits (EP1, mode 1); ``ValueError`` if out
    of that view's range."""
    if isinstance(value, bool):
        raise TypeError("a position is an int, not a bool")
    if signed:
        return f"{check_int(value, POSITION_MIN, SIGNED_MAX, 'a signed position'):+08d}"
    return f"{check_int(value, 0, UNSIGNED_MAX, 'an unsigned position'):08d}"
