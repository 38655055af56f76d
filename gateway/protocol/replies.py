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

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeAlias, TypeVar

from gateway.errors import ReplyFormatError
from gateway.protocol.program import CAPACITY_BYTES
from gateway.protocol.reply_fields import (
    check_int,
    encode_position,
    parse_byte,
    parse_clr_state,
    parse_condition,
    parse_condition_bit,
    parse_decimal,
    parse_error_output,
    parse_inputs_inp,
    parse_motor_pair,
    parse_outputs_clr,
    parse_position,
    parse_program_state,
    parse_program_text,
    parse_sensor_logic,
    parse_sensors,
    parse_speed_point,
    parse_status,
    parse_version,
    show_decimal,
    show_program_text,
    wrap_position,
)
from gateway.protocol.reply_values import (
    ClrState,
    ConditionFlags,
    ErrorOutput,
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


def _decode(fmt: ReplyFormat, parse: Callable[[str], _V], data: str) -> _V:
    """Run ``parse``, turning every rule it or a value type breaks into ReplyFormatError."""
    if not isinstance(data, str):
        raise ReplyFormatError(f"{fmt.name} reply: data must be text, got {type(data).__name__}")
    try:
        return parse(data)
    except ValueError as e:  # the parsers and the value types' range checks
        raise ReplyFormatError(f"{fmt.name} reply {data!r}: {e}") from e


@dataclass(frozen=True)
class _Codec(Generic[_V]):
    kind: type[_V]
    width: int | None  # characters of data; None = variable
    parse: Callable[[str], _V]
    show: Callable[[_V], str]


_R = ReplyFormat
_CODECS: dict[ReplyFormat, _Codec[Any]] = {
    _R.STATUS: _Codec(StatusFlags, 1, parse_status, lambda v: f"{v.nibble:X}"),
    _R.CONDITION: _Codec(ConditionFlags, 2, parse_condition, lambda v: f"{v.byte:02X}"),
    _R.CONDITION_BIT: _Codec(
        int,
        1,
        lambda d: parse_condition_bit(d, None),
        lambda v: str(check_int(v, 0, 2, "a condition bit")),
    ),
    # Both management views are 8 characters; the flag only picks which one is written.
    _R.POSITION: _Codec(
        int, 8, lambda d: parse_position(d, None), lambda v: encode_position(v, signed=False)
    ),
    _R.DIGIT: _Codec(int, 1, parse_decimal(1), show_decimal(1)),
    _R.DEC3: _Codec(int, 3, parse_decimal(3), show_decimal(3)),
    _R.DEC5: _Codec(int, 5, parse_decimal(5), show_decimal(5)),
    _R.INPUTS: _Codec(PortByte, 2, parse_byte, lambda v: f"{v.value:02X}"),
    _R.INPUTS_INP: _Codec(
        InputsWithInp,
        3,
        parse_inputs_inp,
        lambda v: f"{v.inp1 | v.inp2 << 1:X}{v.inputs.value:02X}",
    ),
    _R.SENSORS: _Codec(SensorBits, 2, parse_sensors, lambda v: f"{v.byte:02X}"),
    _R.OUTPUTS: _Codec(PortByte, 2, parse_byte, lambda v: f"{v.value:02X}"),
    _R.OUTPUTS_CLR: _Codec(
        OutputsWithClr,
        3,
        parse_outputs_clr,
        lambda v: f"{v.clr1 | v.clr2 << 1:X}{v.outputs.value:02X}",
    ),
    _R.SENSOR_LOGIC: _Codec(SensorLogic, 2, parse_sensor_logic, lambda v: f"{v.byte:02X}"),
    _R.BUFFER: _Codec(PortByte, 2, parse_byte, lambda v: f"{v.value:02X}"),
    _R.CLR_STATE: _Codec(ClrState, 2, parse_clr_state, lambda v: f"{v.clr2:d}{v.clr1:d}"),
    _R.MOTOR_PAIR: _Codec(
        MotorPair, 2, lambda d: parse_motor_pair(d, 2), lambda v: f"{v.motor2}{v.motor1}"
    ),
    _R.ERROR_OUTPUT: _Codec(
        ErrorOutput,
        4,
        parse_error_output,
        lambda v: f"{int(v.watch):X},{v.outputs.value:02X}",
    ),
    _R.SPEED_POINT: _Codec(
        SpeedPoint, 14, parse_speed_point, lambda v: f"{v.speed:05d},{v.remaining:08d}"
    ),
    _R.PROGRAM_STATE: _Codec(ProgramState, 1, parse_program_state, str),
    _R.PROGRAM_TEXT: _Codec(str, None, parse_program_text, show_program_text),
    _R.VERSION: _Codec(
        Version, 35, parse_version, lambda v: f"RC-233 Ver {v.version} by RORZE ({v.stamp})"
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


def decode_position(data: str, *, signed: bool | None = None) -> int:
    """A POSITION reply (``6``, ``2D``, ``A{pn}D``); ``signed`` as ``decode_reply``'s flag."""
    return _decode(ReplyFormat.POSITION, lambda d: parse_position(d, signed), data)


def decode_condition_bit(data: str, bit: int | None = None) -> int:
    """A ``9{bit}`` reply: 0/1, or the mode 0-2 for bits 4 and 5; None = bit not known."""
    if bit is not None and not 0 <= bit <= 7:
        raise ValueError(f"condition bits are 0-7, got {bit}")
    return _decode(ReplyFormat.CONDITION_BIT, lambda d: parse_condition_bit(d, bit), data)


def decode_motor_pair(data: str, *, max_setting: int = 2) -> MotorPair:
    """A ``QS`` / ``QJ`` / ``QSE`` reply; ``max_setting=1`` for QJ and QSE (QS allows 2)."""
    if max_setting not in (1, 2):
        raise ValueError(f"max_setting is 1 or 2, got {max_setting}")
    return _decode(ReplyFormat.MOTOR_PAIR, lambda d: parse_motor_pair(d, max_setting), data)


def decode_status(data: str) -> StatusFlags:
    """A ``""`` reply: the status flags."""
    return _decode(ReplyFormat.STATUS, parse_status, data)


def decode_condition(data: str) -> ConditionFlags:
    """A ``9`` reply: the condition flags, mode and selected motor."""
    return _decode(ReplyFormat.CONDITION, parse_condition, data)


def decode_digit(data: str) -> int:
    """A one-digit setting or state (``E``, ``EP``, ``C{bit}``, ``CL{bit}`` ...)."""
    return _decode(ReplyFormat.DIGIT, parse_decimal(1), data)


def decode_dec3(data: str) -> int:
    """A three-digit value (``OC``, ``PB``, ``QJT``)."""
    return _decode(ReplyFormat.DEC3, parse_decimal(3), data)


def decode_dec5(data: str) -> int:
    """A five-digit value (speeds, ``0S``, ``BN``, ``GN``, ``GRT`` ...)."""
    return _decode(ReplyFormat.DEC5, parse_decimal(5), data)


def decode_inputs(data: str) -> PortByte:
    """A ``C`` reply: the general input port."""
    return _decode(ReplyFormat.INPUTS, parse_byte, data)


def decode_inputs_inp(data: str) -> InputsWithInp:
    """A ``CA`` reply: INP1/INP2 and the general input port."""
    return _decode(ReplyFormat.INPUTS_INP, parse_inputs_inp, data)


def decode_sensors(data: str) -> SensorBits:
    """A ``CL`` / ``CLM{mt}`` reply: the sensor inputs of one motor."""
    return _decode(ReplyFormat.SENSORS, parse_sensors, data)


def decode_outputs(data: str) -> PortByte:
    """A ``CO`` reply: the general output port."""
    return _decode(ReplyFormat.OUTPUTS, parse_byte, data)


def decode_outputs_clr(data: str) -> OutputsWithClr:
    """A ``COA`` reply: CLR1/CLR2 and the general output port."""
    return _decode(ReplyFormat.OUTPUTS_CLR, parse_outputs_clr, data)


def decode_sensor_logic(data: str) -> SensorLogic:
    """An ``EA`` reply: A/B contact per sensor."""
    return _decode(ReplyFormat.SENSOR_LOGIC, parse_sensor_logic, data)


def decode_buffer(data: str) -> PortByte:
    """A ``GR{bf}`` reply: one user-program data buffer byte."""
    return _decode(ReplyFormat.BUFFER, parse_byte, data)


def decode_clr_state(data: str) -> ClrState:
    """A ``DS`` reply: the CLR outputs."""
    return _decode(ReplyFormat.CLR_STATE, parse_clr_state, data)


def decode_error_output(data: str) -> ErrorOutput:
    """A ``K`` reply: watched errors and output bits."""
    return _decode(ReplyFormat.ERROR_OUTPUT, parse_error_output, data)


def decode_speed_point(data: str) -> SpeedPoint:
    """An ``N{pn}`` reply: one speed-change point."""
    return _decode(ReplyFormat.SPEED_POINT, parse_speed_point, data)


def decode_program_state(data: str) -> ProgramState:
    """A ``GSS`` reply: the user-program state."""
    return _decode(ReplyFormat.PROGRAM_STATE, parse_program_state, data)


def decode_program_text(data: str) -> str:
    """An ``IR`` reply: the user program in RAM ('' when none)."""
    return _decode(ReplyFormat.PROGRAM_TEXT, parse_program_text, data)


def decode_version(data: str) -> Version:
    """A ``V`` reply: the ROM version."""
    return _decode(ReplyFormat.VERSION, parse_version, data)
