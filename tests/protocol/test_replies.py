"""Reply codecs: the manual's reply examples decode to what the manual says they mean, every
value writes back to the same text, and text that does not fit is refused with
ReplyFormatError naming the format."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gateway.errors import ReplyFormatError
from gateway.protocol import replies
from gateway.protocol.command_text import REGISTRY
from gateway.protocol.replies import (
    PROGRAM_MAX,
    ReplyValue,
    decode_condition_bit,
    decode_motor_pair,
    decode_position,
    decode_reply,
    encode_position,
    encode_reply,
    reply_length,
    wrap_position,
)
from gateway.protocol.reply_values import (
    ClrState,
    ConditionFlags,
    Contact,
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

R = ReplyFormat
DATA_FORMATS = [f for f in ReplyFormat if f.has_data]
ACK_FORMATS = [f for f in ReplyFormat if not f.has_data]

# --- the manual's examples, through the catalog ----------------------------------------------

A = Contact.A
B = Contact.B

# (command text after the body number, the manual's wire reply, the value it means). The
# format comes from the catalog, so a form whose ReplyFormat is wrong fails here too.
MANUAL_REPLIES: list[tuple[str, str, Any]] = [
    ("", ">$10\r", StatusFlags()),  # §10 "": no error, stopped
    ("", ">$29\r", StatusFlags(moving=True, command_error=True)),  # 9 = 1001
    ("", ">$1A\r", StatusFlags(limit_error=True, command_error=True)),  # A = 1010
    ("", ">$11\r", StatusFlags(moving=True)),  # §8-2: pulses being output
    ("", ">$12\r", StatusFlags(limit_error=True)),  # §8-2: limit sensor ON
    ("", ">$18\r", StatusFlags(command_error=True)),  # §8-2: command error
    ("9", ">$100\r", ConditionFlags()),  # §10 9: no errors, mode 0, motor 1
    (
        "9",
        ">$19A\r",  # §10 9: command + limit error, mode 1, motor 2
        ConditionFlags(limit_error=True, command_error=True, mode=1, selected_motor=2),
    ),
    ("94", ">$12\r", 2),  # §10 9 form II, bit 4: mode 2
    ("6", ">$100003500\r", 3500),  # §10 6
    ("6", ">$100000300\r", 300),  # §10 EE / EL tables
    ("6", ">$116777215\r", 16_777_215),  # §10 EP table, EP0
    ("6", ">$1-0000001\r", -1),  # §10 EP table, EP1: the same counter
    ("BN", ">$100103\r", 103),  # §10 B: next position number
    ("C", ">$12F\r", PortByte.of(0, 1, 2, 3, 5)),  # §10 C: bits 0-3 and 5 ON
    ("CL", ">$121\r", SensorBits(cw_limit=True, emergency_stop=True)),  # §10 CL: CWLS + EMS
    ("CL4", ">$10\r", 0),  # §10 CL: ORG OFF
    ("GSS", ">$1E\r", ProgramState.ERROR),  # §10 GSS: ended by an error
    ("GSS", ">$10\r", ProgramState.ENDED),  # read again: the error state was cleared
    ("OC", ">$1050\r", 50),  # §10 OC query (3 digits)
    ("OH", ">$105000\r", 5000),  # §10 OH query, the default
    ("QD1", ">$101024\r", 1024),  # §10 Q: period of motor 1
    ("T", ">$11\r", 1),  # §10 T: timer running
    ("T", ">$10\r", 0),  # §10 T: timed up
]


@pytest.mark.parametrize(("command", "wire", "value"), MANUAL_REPLIES)
def test_manual_reply_examples(command: str, wire: str, value: Any) -> None:
    fmt = REGISTRY.matches(command)[0].form.reply
    assert wire.startswith(">$") and wire.endswith("\r")
    data = wire[3:-1]
    decoded = decode_reply(fmt, data)
    assert decoded == value
    assert type(decoded) is type(value)
    assert encode_reply(fmt, decoded, signed_positions=data[:1] in "+-") == data
    assert reply_length(fmt) == len(wire)


def test_sum_examples_carry_the_same_data_after_the_checksum() -> None:
    # §10 SUM: '>$10C3' is the status reply '0' with checksum C3; '>$11C4' is SUM = 1.
    assert decode_reply(R.STATUS, ">$10C3\r"[3:-3]) == StatusFlags()
    assert decode_reply(R.DIGIT, ">$11C4\r"[3:-3]) == 1


# §10 EP table: the same 24-bit counter in both views (row 1-3 reconstructed from the OCR).
EP_TABLE = [
    ("00000000", "+0000000", 0),
    ("08388607", "+8388607", 8_388_607),
    ("08388608", "-8388608", 8_388_608),
    ("16777215", "-0000001", 16_777_215),
]


@pytest.mark.parametrize(("unsigned", "signed", "counter"), EP_TABLE)
def test_ep_table(unsigned: str, signed: str, counter: int) -> None:
    assert decode_position(unsigned, signed=False) == counter
    assert decode_position(signed, signed=True) == wrap_position(counter, True)
    assert wrap_position(decode_position(signed), False) == counter
    assert encode_position(wrap_position(counter, False), signed=False) == unsigned
    assert encode_position(wrap_position(counter, True), signed=True) == signed


def test_wrap_position_past_the_range() -> None:
    # §7-4: in unsigned management a move to -2000 reads 16,775,216.
    assert wrap_position(-2000, False) == 16_775_216
    assert wrap_position(-2000, True) == -2000
    assert wrap_position(16_777_216, False) == 0
    assert wrap_position(8_388_608, True) == -8_388_608


@given(st.integers(-(2**30), 2**30))
def test_wrap_position_views_agree(counter: int) -> None:
    unsigned, signed = wrap_position(counter, False), wrap_position(counter, True)
    assert 0 <= unsigned <= 16_777_215
    assert -8_388_608 <= signed <= 8_388_607
    assert (unsigned - signed) % 2**24 == 0
    assert (unsigned - counter) % 2**24 == 0


@pytest.mark.parametrize(
    ("data", "flags"),
    [  # §10 9: bits 5,4 are the mode, bit 7 the selected motor, bit 6 step-out
        ("00", ConditionFlags(mode=0)),
        ("10", ConditionFlags(mode=1)),
        ("20", ConditionFlags(mode=2)),
        ("40", ConditionFlags(step_out=True)),
        ("80", ConditionFlags(selected_motor=2)),
        ("01", ConditionFlags(communication_error=True)),
        ("04", ConditionFlags(emergency_stop=True)),
        ("EF", ConditionFlags(True, True, True, True, 2, True, 2)),
    ],
)
def test_condition_bits(data: str, flags: ConditionFlags) -> None:
    assert replies.decode_condition(data) == flags
    assert encode_reply(R.CONDITION, flags) == data


def test_condition_bit_knows_which_bits_read_the_mode() -> None:
    assert decode_condition_bit("2", 4) == 2
    assert decode_condition_bit("2", 5) == 2
    assert decode_condition_bit("1", 6) == 1
    with pytest.raises(ReplyFormatError, match="condition bit 6 reads 0-1"):
        decode_condition_bit("2", 6)
    with pytest.raises(ValueError, match="0-7"):
        decode_condition_bit("0", 8)


@pytest.mark.parametrize(
    ("du", "org", "ems", "step_out"),  # §10 CL quick table for DU
    [
        (0, False, False, False),
        (1, True, False, False),
        (2, False, True, False),
        (3, True, True, False),
        (4, False, False, True),
        (5, True, False, True),
        (6, False, True, True),
        (7, True, True, True),
    ],
)
@pytest.mark.parametrize(
    ("dl", "cw", "ccw"), [(0, False, False), (1, True, False), (2, False, True), (3, True, True)]
)
def test_sensor_quick_tables(
    du: int, org: bool, ems: bool, step_out: bool, dl: int, cw: bool, ccw: bool
) -> None:
    bits = replies.decode_sensors(f"{du}{dl}")
    assert bits == SensorBits(
        cw_limit=cw, ccw_limit=ccw, org=org, emergency_stop=ems, step_out_sensor=step_out
    )
    assert encode_reply(R.SENSORS, bits) == f"{du}{dl}"


def test_sensor_logic_of_the_rc231_family() -> None:
    # §10 EA: RC-231 = 00 (all A contact); RC-231HA = 0E (ORG, limits, EZ B contact).
    assert replies.decode_sensor_logic("00") == SensorLogic()
    assert replies.decode_sensor_logic("0E") == SensorLogic(
        step_out_sensor=B, limit=B, org=B, emergency_stop=A, inp=A
    )
    # §6-3 'EA41B' sets EMS to B contact; §13-2 'EA51B' INP high-active (B).
    assert encode_reply(R.SENSOR_LOGIC, SensorLogic(emergency_stop=B)) == "10"
    assert encode_reply(R.SENSOR_LOGIC, SensorLogic(inp=B)) == "20"


@pytest.mark.parametrize(
    ("digit", "first", "second"),
    [("0", False, False), ("1", True, False), ("2", False, True), ("3", True, True)],
)
def test_ip_and_dc_tables(digit: str, first: bool, second: bool) -> None:
    # §10 C IP table (INP1, INP2) and §10 CO DC table (CLR1, CLR2)
    assert replies.decode_inputs_inp(digit + "2F") == InputsWithInp(first, second, PortByte(0x2F))
    assert replies.decode_outputs_clr(digit + "00") == OutputsWithClr(first, second, PortByte())


def test_two_digit_pairs_are_written_motor_2_first() -> None:
    # §10 DS: C2 C1; §10 QS/QJ/QSE: M2 M1 ('QS10' = motor 2 only, §13-2 備考).
    assert replies.decode_clr_state("10") == ClrState(clr1=False, clr2=True)
    assert replies.decode_clr_state("01") == ClrState(clr1=True, clr2=False)
    assert decode_motor_pair("10") == MotorPair(motor1=0, motor2=1)
    assert decode_motor_pair("02") == MotorPair(motor1=2, motor2=0)
    assert decode_motor_pair("11", max_setting=1) == MotorPair(1, 1)
    with pytest.raises(ReplyFormatError, match="0-1 for this command"):
        decode_motor_pair("20", max_setting=1)
    with pytest.raises(ValueError, match="max_setting"):
        decode_motor_pair("00", max_setting=3)


def test_error_output() -> None:
    # §10 K: '0,00' = off (§16 default); K2,FF = EMS -> all outputs; K5,3 = limit or step-out
    # -> output bit 3 (read back as a mask; the manual does not print that reply).
    off = replies.decode_error_output("0,00")
    assert off == ErrorOutput() and not off.enabled
    ems = replies.decode_error_output("2,FF")
    assert ems == ErrorOutput(ErrorWatch.EMERGENCY_STOP, PortByte(0xFF)) and ems.enabled
    assert replies.decode_error_output("5,08") == ErrorOutput(
        ErrorWatch.LIMIT | ErrorWatch.STEP_OUT, PortByte.of(3)
    )
    assert encode_reply(R.ERROR_OUTPUT, ErrorOutput(ErrorWatch(7), PortByte(0xA5))) == "7,A5"


def test_speed_point() -> None:
    # §10 N example: point 1 = speed 8,000 at 20,000 pulses remaining
    assert replies.decode_speed_point("08000,00020000") == SpeedPoint(8000, 20_000)
    assert replies.decode_speed_point("16383,16777215") == SpeedPoint(16_383, 16_777_215)


def test_program_text() -> None:
    program = "/0//JON1+1/END/3//END"  # §11 example
    assert replies.decode_program_text(program) == program
    assert replies.decode_program_text("") == ""  # no program in RAM
    assert replies.decode_program_text("/" * PROGRAM_MAX) == "/" * PROGRAM_MAX


VERSION_TEXT = "RC-233 Ver 1.19 by RORZE (01-02-03)"


def test_version_reply_is_39_characters() -> None:
    assert len(">$1" + VERSION_TEXT + "\r") == 39 == reply_length(R.VERSION)
    version = replies.decode_version(VERSION_TEXT)
    assert version == Version("1.19", "01-02-03")
    assert encode_reply(R.VERSION, version) == VERSION_TEXT


@pytest.mark.parametrize(
    ("version", "lower", "er", "qja", "zero_x", "qs2"),
    [
        ("1.08", False, False, False, False, False),
        ("1.09", False, False, False, False, True),
        ("1.17", False, False, False, False, True),
        ("1.18", True, False, False, False, True),
        ("1.19", True, True, True, False, True),
        ("1.20", True, True, True, True, True),
        ("2.00", True, True, True, True, True),
    ],
)
def test_version_features(
    version: str, lower: bool, er: bool, qja: bool, zero_x: bool, qs2: bool
) -> None:
    v = Version(version, "00-00-00")
    assert v.has_lowercase_labels is lower
    assert v.has_error_display is er
    assert v.has_adjust_limits is qja
    assert v.has_homing_algorithm is zero_x
    assert v.has_step_out_at_rest is qs2


def test_version_compares_numerically() -> None:
    v = Version("1.19", "ab-CD-09")
    assert v.number == (1, 19)
    assert v.at_least("1.19") and v.at_least("1.09") and not v.at_least("1.20")
    assert Version("2.00", "00-00-00").number > v.number
    with pytest.raises(ValueError, match=r"x\.xx"):
        v.at_least("1.2")


# --- reply lengths (§15) ---------------------------------------------------------------------

SECTION_15_LENGTHS = {
    R.STATUS: 5,  # ""
    R.CONDITION: 6,  # 9
    R.CONDITION_BIT: 5,  # 9{bit}
    R.POSITION: 12,  # 6, 2D, A{pn}D
    R.INPUTS: 6,  # C
    R.SENSORS: 6,  # CL
    R.OUTPUTS: 6,  # CO
    R.SENSOR_LOGIC: 6,  # EA
    R.CLR_STATE: 6,  # DS
    R.INPUTS_INP: 7,  # CA
    R.OUTPUTS_CLR: 7,  # COA
    R.VERSION: 39,  # V
    R.DEC5: 9,  # 0S, OH ... (by the §10 formats)
    R.DIGIT: 5,  # E, ED, EL ...
    R.DEC3: 7,  # OC
    R.ERROR_OUTPUT: 8,  # K
    R.BUFFER: 6,  # GR{bf}
    R.MOTOR_PAIR: 6,  # QS
    R.PROGRAM_TEXT: None,  # IR: variable
}


@pytest.mark.parametrize(("fmt", "length"), SECTION_15_LENGTHS.items())
def test_reply_lengths_of_section_15(fmt: ReplyFormat, length: int | None) -> None:
    assert reply_length(fmt) == length


@pytest.mark.parametrize("fmt", ACK_FORMATS)
def test_formats_without_data_have_no_codec(fmt: ReplyFormat) -> None:
    with pytest.raises(ValueError, match="carry no data"):
        reply_length(fmt)
    with pytest.raises(ValueError, match="carry no data"):
        decode_reply(fmt, "0")
    with pytest.raises(ValueError, match="carry no data"):
        encode_reply(fmt, 0)


# --- every format: round trips ---------------------------------------------------------------

PORT = st.builds(PortByte, st.integers(0, 255))
STAMP = st.text("0123456789ABCabc", min_size=2, max_size=2)
PROGRAM_CHARS = st.characters(
    min_codepoint=0x20, max_codepoint=0x7E, exclude_characters="$"
) | st.characters(min_codepoint=0xFF61, max_codepoint=0xFF9F)

VALUES: dict[ReplyFormat, st.SearchStrategy[Any]] = {
    R.STATUS: st.builds(StatusFlags, st.booleans(), st.booleans(), st.booleans(), st.booleans()),
    R.CONDITION: st.builds(
        ConditionFlags,
        st.booleans(),
        st.booleans(),
        st.booleans(),
        st.booleans(),
        st.integers(0, 2),
        st.booleans(),
        st.sampled_from([1, 2]),
    ),
    R.CONDITION_BIT: st.integers(0, 2),
    R.POSITION: st.integers(0, 16_777_215),  # unsigned view; the signed one is tested apart
    R.DIGIT: st.integers(0, 9),
    R.DEC3: st.integers(0, 999),
    R.DEC5: st.integers(0, 99_999),
    R.INPUTS: PORT,
    R.INPUTS_INP: st.builds(InputsWithInp, st.booleans(), st.booleans(), PORT),
    R.SENSORS: st.builds(
        SensorBits, st.booleans(), st.booleans(), st.booleans(), st.booleans(), st.booleans()
    ),
    R.OUTPUTS: PORT,
    R.OUTPUTS_CLR: st.builds(OutputsWithClr, st.booleans(), st.booleans(), PORT),
    R.SENSOR_LOGIC: st.builds(SensorLogic, *[st.sampled_from(Contact)] * 5),
    R.BUFFER: PORT,
    R.CLR_STATE: st.builds(ClrState, st.booleans(), st.booleans()),
    R.MOTOR_PAIR: st.builds(MotorPair, st.integers(0, 2), st.integers(0, 2)),
    R.ERROR_OUTPUT: st.builds(ErrorOutput, st.integers(0, 7).map(ErrorWatch), PORT),
    R.SPEED_POINT: st.builds(SpeedPoint, st.integers(0, 16_383), st.integers(0, 16_777_215)),
    R.PROGRAM_STATE: st.sampled_from(ProgramState),
    R.PROGRAM_TEXT: st.just("") | st.text(PROGRAM_CHARS, max_size=80).map(lambda s: "/" + s),
    R.VERSION: st.builds(
        Version,
        st.builds(lambda a, b: f"{a}.{b:02d}", st.integers(0, 9), st.integers(0, 99)),
        st.builds(lambda a, b, c: f"{a}-{b}-{c}", STAMP, STAMP, STAMP),
    ),
}


def test_every_data_format_has_a_codec() -> None:
    # A ReplyFormat member added without a codec (or without a strategy here) fails.
    assert set(VALUES) == set(DATA_FORMATS)
    for fmt in DATA_FORMATS:
        decoder = getattr(replies, f"decode_{fmt.value}")
        assert callable(decoder)
        length = reply_length(fmt)
        assert length is None or length >= 5


@settings(max_examples=300)
@given(st.data())
def test_round_trip_value_text_value(data: st.DataObject) -> None:
    fmt = data.draw(st.sampled_from(DATA_FORMATS))
    value = data.draw(VALUES[fmt])
    text = encode_reply(fmt, value)
    assert decode_reply(fmt, text) == value
    assert getattr(replies, f"decode_{fmt.value}")(text) == value
    assert encode_reply(fmt, decode_reply(fmt, text)) == text
    length = reply_length(fmt)
    if length is not None:
        assert len(">$1" + text + "\r") == length


@given(st.integers(-8_388_608, 8_388_607))
def test_round_trip_signed_positions(value: int) -> None:
    text = encode_position(value, signed=True)
    assert len(text) == 8 and text[0] in "+-"
    assert decode_position(text, signed=True) == value
    assert decode_reply(R.POSITION, text) == value
    assert encode_reply(R.POSITION, value, signed_positions=True) == text


# Characters that appear in some reply, so that fuzzed text sometimes fits.
FUZZ_ALPHABET = "0123456789ABCDEFaf+-,/PE $\r"


def _canonical(fmt: ReplyFormat, text: str) -> None:
    """``text`` either fails with ReplyFormatError naming ``fmt`` or is canonical."""
    try:
        value: ReplyValue = decode_reply(fmt, text)
    except ReplyFormatError as e:
        assert fmt.name in str(e)
        return
    assert encode_reply(fmt, value, signed_positions=text[:1] in "+-") == text


@settings(max_examples=500)
@given(st.sampled_from(DATA_FORMATS), st.text(FUZZ_ALPHABET, max_size=16))
def test_any_text_decodes_canonically_or_fails_cleanly(fmt: ReplyFormat, text: str) -> None:
    _canonical(fmt, text)


@settings(max_examples=500)
@given(st.data())
def test_mutated_replies_decode_canonically_or_fail_cleanly(data: st.DataObject) -> None:
    fmt = data.draw(st.sampled_from(DATA_FORMATS))
    text = encode_reply(fmt, data.draw(VALUES[fmt]))
    i = data.draw(st.integers(0, len(text)))
    c = data.draw(st.sampled_from(FUZZ_ALPHABET + "GZz \t"))
    edit = data.draw(st.sampled_from(["replace", "insert", "delete"]))
    if edit == "replace":
        text = text[:i] + c + text[i + 1 :]
    elif edit == "insert":
        text = text[:i] + c + text[i:]
    else:
        text = text[:i] + text[i + 1 :]
    _canonical(fmt, text)


# --- text that does not fit ------------------------------------------------------------------

BAD: list[tuple[ReplyFormat, str, str]] = [
    (R.STATUS, "", "one upper-case hex digit"),
    (R.STATUS, "00", "one upper-case hex digit"),
    (R.STATUS, "a", "one upper-case hex digit"),  # lower case
    (R.STATUS, "G", "one upper-case hex digit"),
    (R.STATUS, "0\r", "one upper-case hex digit"),
    (R.CONDITION, "0", "two upper-case hex digits"),
    (R.CONDITION, "000", "two upper-case hex digits"),
    (R.CONDITION, "9a", "two upper-case hex digits"),
    (R.CONDITION, "30", "bits 5,4 = 11 are unused"),  # mode 3
    (R.CONDITION, "B0", "bits 5,4 = 11 are unused"),
    (R.CONDITION_BIT, "3", "reads 0-2"),
    (R.CONDITION_BIT, "01", "one decimal digit"),
    (R.CONDITION_BIT, "A", "one decimal digit"),
    (R.POSITION, "0003500", "expected 8 digits"),  # 7 digits without a sign
    (R.POSITION, "000003500", "expected 8 digits"),  # 9 digits
    (R.POSITION, "+00003500", "expected 8 digits"),  # sign + 8 digits
    (R.POSITION, "+003500", "expected 8 digits"),  # sign + 6 digits
    (R.POSITION, "0000350+", "expected 8 digits"),  # sign at the end
    (R.POSITION, "00-00001", "expected 8 digits"),  # sign in the middle
    (R.POSITION, " 0003500", "expected 8 digits"),
    (R.POSITION, "16777216", "unsigned positions end at 16777215"),
    (R.POSITION, "99999999", "unsigned positions end at 16777215"),
    (R.POSITION, "+8388608", "signed positions are -8388608..+8388607"),
    (R.POSITION, "-8388609", "signed positions are -8388608..+8388607"),
    (R.POSITION, "-0000000", "zero is written '+0000000'"),
    (R.DIGIT, "", "one decimal digit"),
    (R.DIGIT, "10", "one decimal digit"),
    (R.DIGIT, "\u0661", "one decimal digit"),  # ARABIC-INDIC DIGIT ONE is not ASCII
    (R.DEC3, "50", "3 digits"),
    (R.DEC3, "0050", "3 digits"),
    (R.DEC3, "+50", "3 digits"),
    (R.DEC5, "5000", "5 digits"),
    (R.DEC5, "005000", "5 digits"),
    (R.DEC5, "-5000", "5 digits"),
    (R.INPUTS, "2", "two upper-case hex digits"),
    (R.INPUTS, "2F0", "two upper-case hex digits"),
    (R.INPUTS, "2f", "two upper-case hex digits"),
    (R.INPUTS_INP, "42F", "IP must be 0-3"),
    (R.INPUTS_INP, "2F", "three upper-case hex digits IP"),
    (R.OUTPUTS, "G0", "two upper-case hex digits"),
    (R.OUTPUTS_CLR, "F00", "DC must be 0-3"),
    (R.OUTPUTS_CLR, "1000", "three upper-case hex digits DC"),
    (R.SENSORS, "04", "unused sensor bit(s) [2]"),
    (R.SENSORS, "08", "unused sensor bit(s) [3]"),
    (R.SENSORS, "80", "unused sensor bit(s) [7]"),
    (R.SENSORS, "1", "two upper-case hex digits"),
    (R.SENSOR_LOGIC, "01", "unused sensor-logic bit(s) [0]"),
    (R.SENSOR_LOGIC, "C0", "unused sensor-logic bit(s) [6, 7]"),
    (R.BUFFER, "100", "two upper-case hex digits"),
    (R.CLR_STATE, "20", "two digits 0/1"),
    (R.CLR_STATE, "1", "two digits 0/1"),
    (R.MOTOR_PAIR, "30", "two digits 0-2"),
    (R.MOTOR_PAIR, "012", "two digits 0-2"),
    (R.ERROR_OUTPUT, "8,00", "watch (DT) must be 0-7"),
    (R.ERROR_OUTPUT, "0,0", "DT ',' DU DL"),
    (R.ERROR_OUTPUT, "000", "DT ',' DU DL"),
    (R.ERROR_OUTPUT, "00,00", "DT ',' DU DL"),
    (R.ERROR_OUTPUT, "0,0f", "DT ',' DU DL"),
    (R.SPEED_POINT, "16384,00000000", "speed (sp) must be 0-16383"),
    (R.SPEED_POINT, "00000,16777216", "remaining (pj) must be 0-16777215"),
    (R.SPEED_POINT, "0000,00000000", "5 digits ',' 8 digits"),
    (R.SPEED_POINT, "00000;00000000", "5 digits ',' 8 digits"),
    (R.PROGRAM_STATE, "2", "one of 1, 0, P, E"),
    (R.PROGRAM_STATE, "e", "one of 1, 0, P, E"),
    (R.PROGRAM_STATE, "", "one of 1, 0, P, E"),
    (R.PROGRAM_TEXT, "0//END", "starts with '/'"),
    (R.PROGRAM_TEXT, "/A$1/END", "no '$', CR or LF"),
    (R.PROGRAM_TEXT, "/END\r", "no '$', CR or LF"),
    (R.PROGRAM_TEXT, "/" * (PROGRAM_MAX + 1), f"at most {PROGRAM_MAX} characters"),
    (R.VERSION, VERSION_TEXT + " ", "RC-233 Ver x.xx"),
    (R.VERSION, VERSION_TEXT.replace("RC-233 Ver", "RC-233Ver"), "RC-233 Ver x.xx"),
    (R.VERSION, VERSION_TEXT.replace("1.19", "1.1"), "RC-233 Ver x.xx"),
    (R.VERSION, VERSION_TEXT.replace("(01-02-03)", "01-02-03"), "RC-233 Ver x.xx"),
    (R.VERSION, VERSION_TEXT.replace("RC-233", "RC-234"), "RC-233 Ver x.xx"),
]


@pytest.mark.parametrize(("fmt", "data", "why"), BAD)
def test_text_that_does_not_fit_is_refused(fmt: ReplyFormat, data: str, why: str) -> None:
    with pytest.raises(ReplyFormatError) as info:
        decode_reply(fmt, data)
    message = str(info.value)
    assert message.startswith(f"{fmt.name} reply ")
    assert why in message


@pytest.mark.parametrize(
    ("data", "signed", "why"),
    [
        ("00003500", True, "expected a sign and 7 digits"),
        ("+0003500", False, "expected 8 digits (unsigned management: EP0), got a sign"),
        ("-0003500", False, "got a sign"),
    ],
)
def test_position_view_must_match_when_known(data: str, signed: bool, why: str) -> None:
    with pytest.raises(ReplyFormatError, match=r"^POSITION reply") as info:
        decode_reply(R.POSITION, data, signed_positions=signed)
    assert why in str(info.value)
    assert decode_reply(R.POSITION, data, signed_positions=not signed) == int(data)


def test_data_that_is_not_text_is_refused() -> None:
    with pytest.raises(ReplyFormatError, match="data must be text"):
        decode_reply(R.STATUS, b"0")  # type: ignore[arg-type]


# --- encoders refuse what the controller could not send --------------------------------------


@pytest.mark.parametrize(
    ("fmt", "value", "error"),
    [
        (R.STATUS, 3, TypeError),
        (R.DIGIT, True, TypeError),  # a bool is not a digit
        (R.DIGIT, "1", TypeError),
        (R.INPUTS, 0x2F, TypeError),
        (R.POSITION, "3500", TypeError),
        (R.DIGIT, 10, ValueError),
        (R.DEC3, -1, ValueError),
        (R.DEC5, 100_000, ValueError),
        (R.CONDITION_BIT, 3, ValueError),
        (R.POSITION, 16_777_216, ValueError),
        (R.POSITION, -1, ValueError),  # negative needs the signed view
        (R.PROGRAM_TEXT, "0//END", ValueError),
    ],
)
def test_encode_refuses(fmt: ReplyFormat, value: Any, error: type[Exception]) -> None:
    with pytest.raises(error):
        encode_reply(fmt, value)


def test_encode_position_views() -> None:
    assert encode_position(3500, signed=False) == "00003500"
    assert encode_position(0, signed=True) == "+0000000"
    assert encode_position(-8_388_608, signed=True) == "-8388608"
    with pytest.raises(ValueError, match="signed position"):
        encode_position(8_388_608, signed=True)
    with pytest.raises(TypeError):
        encode_position(True, signed=False)


# --- value types -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "build",
    [
        lambda: PortByte(256),
        lambda: PortByte(-1),
        lambda: PortByte.of(8),
        lambda: PortByte().with_bit(8, True),
        lambda: StatusFlags.from_nibble(16),
        lambda: ConditionFlags(mode=3),
        lambda: ConditionFlags(selected_motor=0),
        lambda: ConditionFlags.from_byte(0x100),
        lambda: SensorBits.from_byte(-1),
        lambda: MotorPair(motor1=3),
        lambda: MotorPair(motor2=-1),
        lambda: SpeedPoint(16_384, 0),
        lambda: SpeedPoint(0, -1),
        lambda: ErrorOutput(ErrorWatch(8)),
        lambda: Version("1.1", "00-00-00"),
        lambda: Version("1.19", "2020-01-01"),
    ],
)
def test_value_types_check_their_ranges(build: Any) -> None:
    with pytest.raises(ValueError):
        build()


def test_port_byte_bit_access() -> None:
    port = PortByte(0x2F)
    assert [port[n] for n in range(8)] == [True, True, True, True, False, True, False, False]
    assert port.on == frozenset({0, 1, 2, 3, 5})
    assert port.with_bit(7, True) == PortByte(0xAF)
    assert port.with_bit(0, False) == PortByte(0x2E)
    assert PortByte.of() == PortByte()
    with pytest.raises(IndexError):
        port[8]


def test_status_helpers() -> None:
    assert not StatusFlags(moving=True).has_error
    assert StatusFlags(emergency_stop=True).has_error
    assert StatusFlags.from_nibble(0xA).nibble == 0xA
    assert ConditionFlags.from_byte(0x9A).byte == 0x9A
    assert SensorBits.from_byte(0x21).byte == 0x21
    assert SensorLogic.from_byte(0x0E).byte == 0x0E
