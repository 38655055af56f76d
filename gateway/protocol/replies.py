"""Query replies: the data part of ``>$B#`` data CR, decoded to typed values and back (§9-2).

``decode_reply`` turns the data (framing and checksum already removed) into the value of its
``ReplyFormat``; ``encode_reply`` writes a value back as the controller would (the simulator
builds its replies with it). Widths are exact: a 5-digit value is exactly 5 digits, hex digits
are upper case, and anything else raises ``ReplyFormatError`` naming the format and the rule,
never another exception. ``encode_reply(decode_reply(t)) == t`` for every text that decodes,
so there is one spelling per value. Choices where the manual is unclear:
docs/manual-notes.md, "Replies".
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeAlias, TypeVar

from gateway.errors import ReplyFormatError
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
from gateway.protocol.spec import ReplyFormat

__all__ = [
    "PROGRAM_MAX",
    "REPLY_OVERHEAD",
    "ReplyValue",
    "decode_buffer",
    "decode_clr_state",
    "decode_condition",
    "decode_condition_bit",
    "decode_dec3",
    "decode_dec5",
    "decode_digit",
    "decode_error_output",
    "decode_inputs",
    "decode_inputs_inp",
    "decode_motor_pair",
    "decode_outputs",
    "decode_outputs_clr",
    "decode_position",
    "decode_program_state",
    "decode_program_text",
    "decode_reply",
    "decode_sensor_logic",
    "decode_sensors",
    "decode_speed_point",
    "decode_status",
    "decode_version",
    "encode_position",
    "encode_reply",
    "reply_length",
    "wrap_position",
]

#: What a data-bearing reply can decode to; ``int`` for positions, digits, DEC3/DEC5 and
#: single condition bits, ``str`` for the program text of ``IR``.
ReplyValue: TypeAlias = (
    StatusFlags
    | ConditionFlags
    | int
    | PortByte
    | InputsWithInp
    | OutputsWithClr
    | SensorBits
    | SensorLogic
    | ClrState
    | MotorPair
    | ErrorOutput
    | SpeedPoint
    | ProgramState
    | str
    | Version
)

#: '>', '$', the body number and CR around the data of a plain query reply (§9-2 form II).
REPLY_OVERHEAD = 4
#: User-program capacity in bytes (§3, §10 I, IR): no ``IR`` reply can be longer.
PROGRAM_MAX = CAPACITY_BYTES

_V = TypeVar("_V")

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


def _match(pattern: re.Pattern[str], data: str, rule: str) -> re.Match[str]:
    m = pattern.fullmatch(data)
    if m is None:
        raise ValueError(f"expected {rule}")
    return m


def _decode(fmt: ReplyFormat, parse: Callable[[str], _V], data: str) -> _V:
    """Run ``parse``, turning every rule it or a value type breaks into ReplyFormatError."""
    if not isinstance(data, str):
        raise ReplyFormatError(f"{fmt.name} reply: data must be text, got {type(data).__name__}")
    try:
        return parse(data)
    except ValueError as e:  # the parsers and the value types' range checks
        raise ReplyFormatError(f"{fmt.name} reply {data!r}: {e}") from e


# --- parsers (text -> value; ValueError on a rule) and writers (value -> text) -------------


def _parse_status(data: str) -> StatusFlags:
    _match(_HEX1, data, "one upper-case hex digit")
    return StatusFlags.from_nibble(int(data, 16))


def _parse_condition(data: str) -> ConditionFlags:
    _match(_HEX2, data, "two upper-case hex digits DU DL")
    return ConditionFlags.from_byte(int(data, 16))


def _parse_condition_bit(data: str, bit: int | None) -> int:
    _match(_DECIMAL[1], data, "one decimal digit")
    # Bits 4 and 5 answer the mode number (0-2); the other bits 0 or 1 (§10 9 form II).
    top = 2 if bit in (None, 4, 5) else 1
    if int(data) > top:
        which = "a condition bit" if bit is None else f"condition bit {bit}"
        raise ValueError(f"{which} reads 0-{top}")
    return int(data)


def _parse_position(data: str, signed: bool | None) -> int:
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


def _parse_decimal(width: int) -> Callable[[str], int]:
    def parse(data: str) -> int:
        _match(_DECIMAL[width], data, "one decimal digit" if width == 1 else f"{width} digits")
        return int(data)

    return parse


def _parse_byte(data: str) -> PortByte:
    _match(_HEX2, data, "two upper-case hex digits DU DL")
    return PortByte(int(data, 16))


def _parse_flagged_byte(data: str, name: str) -> tuple[bool, bool, PortByte]:
    m = _match(_HEX3, data, f"three upper-case hex digits {name} DU DL")
    pair = int(m[1], 16)
    if pair > 3:  # two bits only: bit 0 = INP1/CLR1, bit 1 = INP2/CLR2
        raise ValueError(f"{name} must be 0-3, got {m[1]}")
    return bool(pair & 1), bool(pair & 2), PortByte(int(m[2], 16))


def _parse_inputs_inp(data: str) -> InputsWithInp:
    return InputsWithInp(*_parse_flagged_byte(data, "IP"))


def _parse_outputs_clr(data: str) -> OutputsWithClr:
    return OutputsWithClr(*_parse_flagged_byte(data, "DC"))


def _parse_sensors(data: str) -> SensorBits:
    _match(_HEX2, data, "two upper-case hex digits DU DL")
    return SensorBits.from_byte(int(data, 16))


def _parse_sensor_logic(data: str) -> SensorLogic:
    _match(_HEX2, data, "two upper-case hex digits DU DL")
    return SensorLogic.from_byte(int(data, 16))


def _parse_clr_state(data: str) -> ClrState:
    _match(_PAIR01, data, "two digits 0/1: CLR2 then CLR1")
    return ClrState(clr1=data[1] == "1", clr2=data[0] == "1")


def _parse_motor_pair(data: str, max_setting: int) -> MotorPair:
    _match(_PAIR02, data, "two digits 0-2: motor 2 then motor 1")
    pair = MotorPair(motor1=int(data[1]), motor2=int(data[0]))
    if max(pair.motor1, pair.motor2) > max_setting:
        raise ValueError(f"settings are 0-{max_setting} for this command")
    return pair


def _parse_error_output(data: str) -> ErrorOutput:
    m = _match(_ERROR_OUTPUT, data, "DT ',' DU DL (upper-case hex, e.g. '0,00')")
    return ErrorOutput(ErrorWatch(int(m[1], 16)), PortByte(int(m[2], 16)))


def _parse_speed_point(data: str) -> SpeedPoint:
    m = _match(_SPEED_POINT, data, "5 digits ',' 8 digits (sp,pj)")
    return SpeedPoint(int(m[1]), int(m[2]))


def _parse_program_state(data: str) -> ProgramState:
    try:
        return ProgramState(data)
    except ValueError:
        raise ValueError("expected one of 1, 0, P, E") from None


def _parse_program_text(data: str) -> str:
    # Empty means no program in RAM; the manual does not show that reply
    # (docs/manual-notes.md, "`IR` reply").
    if data and not data.startswith("/"):
        raise ValueError("a user program starts with '/'")
    if any(c in "$\r\n" for c in data):  # '$' starts a command, CR ends the frame (§10 I)
        raise ValueError("a user program holds no '$', CR or LF")
    if len(data) > PROGRAM_MAX:
        raise ValueError(f"a user program is at most {PROGRAM_MAX} characters, got {len(data)}")
    return data


def _parse_version(data: str) -> Version:
    m = _match(_VERSION, data, "'RC-233 Ver x.xx by RORZE (xx-xx-xx)' (35 characters)")
    return Version(m[1], m[2])


def _check_int(value: int, lo: int, hi: int, what: str) -> int:
    if not lo <= value <= hi:
        raise ValueError(f"{what} must be {lo}..{hi}, got {value}")
    return value


def _show_decimal(width: int) -> Callable[[int], str]:
    def show(value: int) -> str:
        return f"{_check_int(value, 0, 10**width - 1, f'a {width}-digit value'):0{width}d}"

    return show


def _show_program_text(value: str) -> str:
    return _parse_program_text(value)  # the same rules bind what the simulator may send


@dataclass(frozen=True)
class _Codec(Generic[_V]):
    kind: type[_V]
    width: int | None  # characters of data; None = variable
    parse: Callable[[str], _V]
    show: Callable[[_V], str]


_R = ReplyFormat
_CODECS: dict[ReplyFormat, _Codec[Any]] = {
    _R.STATUS: _Codec(StatusFlags, 1, _parse_status, lambda v: f"{v.nibble:X}"),
    _R.CONDITION: _Codec(ConditionFlags, 2, _parse_condition, lambda v: f"{v.byte:02X}"),
    _R.CONDITION_BIT: _Codec(
        int,
        1,
        lambda d: _parse_condition_bit(d, None),
        lambda v: str(_check_int(v, 0, 2, "a condition bit")),
    ),
    # Both management views are 8 characters; the flag only picks which one is written.
    _R.POSITION: _Codec(
        int, 8, lambda d: _parse_position(d, None), lambda v: encode_position(v, signed=False)
    ),
    _R.DIGIT: _Codec(int, 1, _parse_decimal(1), _show_decimal(1)),
    _R.DEC3: _Codec(int, 3, _parse_decimal(3), _show_decimal(3)),
    _R.DEC5: _Codec(int, 5, _parse_decimal(5), _show_decimal(5)),
    _R.INPUTS: _Codec(PortByte, 2, _parse_byte, lambda v: f"{v.value:02X}"),
    _R.INPUTS_INP: _Codec(
        InputsWithInp,
        3,
        _parse_inputs_inp,
        lambda v: f"{v.inp1 | v.inp2 << 1:X}{v.inputs.value:02X}",
    ),
    _R.SENSORS: _Codec(SensorBits, 2, _parse_sensors, lambda v: f"{v.byte:02X}"),
    _R.OUTPUTS: _Codec(PortByte, 2, _parse_byte, lambda v: f"{v.value:02X}"),
    _R.OUTPUTS_CLR: _Codec(
        OutputsWithClr,
        3,
        _parse_outputs_clr,
        lambda v: f"{v.clr1 | v.clr2 << 1:X}{v.outputs.value:02X}",
    ),
    _R.SENSOR_LOGIC: _Codec(SensorLogic, 2, _parse_sensor_logic, lambda v: f"{v.byte:02X}"),
    _R.BUFFER: _Codec(PortByte, 2, _parse_byte, lambda v: f"{v.value:02X}"),
    _R.CLR_STATE: _Codec(ClrState, 2, _parse_clr_state, lambda v: f"{v.clr2:d}{v.clr1:d}"),
    _R.MOTOR_PAIR: _Codec(
        MotorPair, 2, lambda d: _parse_motor_pair(d, 2), lambda v: f"{v.motor2}{v.motor1}"
    ),
    _R.ERROR_OUTPUT: _Codec(
        ErrorOutput,
        4,
        _parse_error_output,
        lambda v: f"{int(v.watch):X},{v.outputs.value:02X}",
    ),
    _R.SPEED_POINT: _Codec(
        SpeedPoint, 14, _parse_speed_point, lambda v: f"{v.speed:05d},{v.remaining:08d}"
    ),
    _R.PROGRAM_STATE: _Codec(ProgramState, 1, _parse_program_state, str),
    _R.PROGRAM_TEXT: _Codec(str, None, _parse_program_text, _show_program_text),
    _R.VERSION: _Codec(
        Version, 35, _parse_version, lambda v: f"RC-233 Ver {v.version} by RORZE ({v.stamp})"
    ),
}


def _codec(fmt: ReplyFormat) -> _Codec[Any]:
    codec = _CODECS.get(fmt)
    if codec is None:
        raise ValueError(f"{fmt.name} replies carry no data ('>' only, or never sent)")
    return codec


# --- public API -----------------------------------------------------------------------------


def decode_reply(
    fmt: ReplyFormat, data: str, *, signed_positions: bool | None = None
) -> ReplyValue:
    """Decode the data part of a ``fmt`` reply; ``ReplyFormatError`` if it does not fit.

    ``signed_positions`` applies to POSITION only: None accepts either management view,
    True only sign + 7 digits (EP1 or mode 1), False only 8 digits (EP0). A format without
    data (ACK ...) raises ``ValueError``: that is the caller's mistake, not the device's.
    """
    if fmt is ReplyFormat.POSITION:
        return decode_position(data, signed=signed_positions)
    decoded: ReplyValue = _decode(fmt, _codec(fmt).parse, data)
    return decoded


def encode_reply(fmt: ReplyFormat, value: ReplyValue, *, signed_positions: bool = False) -> str:
    """The data part the controller sends for ``value`` (the inverse of ``decode_reply``).

    Raises ``TypeError`` when ``value`` is not of the format's type and ``ValueError`` when
    it is out of the format's range; positions are not wrapped (see ``wrap_position``).
    """
    if fmt is ReplyFormat.POSITION:
        if not isinstance(value, int):
            raise TypeError(f"POSITION replies encode an int, got {type(value).__name__}")
        return encode_position(value, signed=signed_positions)
    codec = _codec(fmt)
    if not isinstance(value, codec.kind) or isinstance(value, bool):
        want = codec.kind.__name__
        raise TypeError(f"{fmt.name} replies encode a {want}, got {type(value).__name__}")
    text: str = codec.show(value)
    return text


def reply_length(fmt: ReplyFormat) -> int | None:
    """Characters of the whole plain reply ``>$B#`` data CR; None when variable (``IR``).

    Plain = no echo (EE), no checksum (SUM). Both position views are 12 characters. A format
    without data raises ``ValueError``.
    """
    width = _codec(fmt).width
    return None if width is None else REPLY_OVERHEAD + width


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
        return f"{_check_int(value, POSITION_MIN, SIGNED_MAX, 'a signed position'):+08d}"
    return f"{_check_int(value, 0, UNSIGNED_MAX, 'an unsigned position'):08d}"


def decode_position(data: str, *, signed: bool | None = None) -> int:
    """A POSITION reply (``6``, ``2D``, ``A{pn}D``); ``signed`` as ``decode_reply``'s flag."""
    return _decode(ReplyFormat.POSITION, lambda d: _parse_position(d, signed), data)


def decode_condition_bit(data: str, bit: int | None = None) -> int:
    """A ``9{bit}`` reply: 0/1, or the mode 0-2 for bits 4 and 5; None = bit not known."""
    if bit is not None and not 0 <= bit <= 7:
        raise ValueError(f"condition bits are 0-7, got {bit}")
    return _decode(ReplyFormat.CONDITION_BIT, lambda d: _parse_condition_bit(d, bit), data)


def decode_motor_pair(data: str, *, max_setting: int = 2) -> MotorPair:
    """A ``QS`` / ``QJ`` / ``QSE`` reply; ``max_setting=1`` for QJ and QSE (QS allows 2)."""
    if max_setting not in (1, 2):
        raise ValueError(f"max_setting is 1 or 2, got {max_setting}")
    return _decode(ReplyFormat.MOTOR_PAIR, lambda d: _parse_motor_pair(d, max_setting), data)


def decode_status(data: str) -> StatusFlags:
    """A ``""`` reply: the status flags."""
    return _decode(ReplyFormat.STATUS, _parse_status, data)


def decode_condition(data: str) -> ConditionFlags:
    """A ``9`` reply: the condition flags, mode and selected motor."""
    return _decode(ReplyFormat.CONDITION, _parse_condition, data)


def decode_digit(data: str) -> int:
    """A one-digit setting or state (``E``, ``EP``, ``C{bit}``, ``CL{bit}`` ...)."""
    return _decode(ReplyFormat.DIGIT, _parse_decimal(1), data)


def decode_dec3(data: str) -> int:
    """A three-digit value (``OC``, ``PB``, ``QJT``)."""
    return _decode(ReplyFormat.DEC3, _parse_decimal(3), data)


def decode_dec5(data: str) -> int:
    """A five-digit value (speeds, ``0S``, ``BN``, ``GN``, ``GRT`` ...)."""
    return _decode(ReplyFormat.DEC5, _parse_decimal(5), data)


def decode_inputs(data: str) -> PortByte:
    """A ``C`` reply: the general input port."""
    return _decode(ReplyFormat.INPUTS, _parse_byte, data)


def decode_inputs_inp(data: str) -> InputsWithInp:
    """A ``CA`` reply: INP1/INP2 and the general input port."""
    return _decode(ReplyFormat.INPUTS_INP, _parse_inputs_inp, data)


def decode_sensors(data: str) -> SensorBits:
    """A ``CL`` / ``CLM{mt}`` reply: the sensor inputs of one motor."""
    return _decode(ReplyFormat.SENSORS, _parse_sensors, data)


def decode_outputs(data: str) -> PortByte:
    """A ``CO`` reply: the general output port."""
    return _decode(ReplyFormat.OUTPUTS, _parse_byte, data)


def decode_outputs_clr(data: str) -> OutputsWithClr:
    """A ``COA`` reply: CLR1/CLR2 and the general output port."""
    return _decode(ReplyFormat.OUTPUTS_CLR, _parse_outputs_clr, data)


def decode_sensor_logic(data: str) -> SensorLogic:
    """An ``EA`` reply: A/B contact per sensor."""
    return _decode(ReplyFormat.SENSOR_LOGIC, _parse_sensor_logic, data)


def decode_buffer(data: str) -> PortByte:
    """A ``GR{bf}`` reply: one user-program data buffer byte."""
    return _decode(ReplyFormat.BUFFER, _parse_byte, data)


def decode_clr_state(data: str) -> ClrState:
    """A ``DS`` reply: the CLR outputs."""
    return _decode(ReplyFormat.CLR_STATE, _parse_clr_state, data)


def decode_error_output(data: str) -> ErrorOutput:
    """A ``K`` reply: watched errors and output bits."""
    return _decode(ReplyFormat.ERROR_OUTPUT, _parse_error_output, data)


def decode_speed_point(data: str) -> SpeedPoint:
    """An ``N{pn}`` reply: one speed-change point."""
    return _decode(ReplyFormat.SPEED_POINT, _parse_speed_point, data)


def decode_program_state(data: str) -> ProgramState:
    """A ``GSS`` reply: the user-program state."""
    return _decode(ReplyFormat.PROGRAM_STATE, _parse_program_state, data)


def decode_program_text(data: str) -> str:
    """An ``IR`` reply: the user program in RAM ('' when none)."""
    return _decode(ReplyFormat.PROGRAM_TEXT, _parse_program_text, data)


def decode_version(data: str) -> Version:
    """A ``V`` reply: the ROM version."""
    return _decode(ReplyFormat.VERSION, _parse_version, data)
