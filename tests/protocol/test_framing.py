"""Framing: wire text, checksums, command frames, device replies, the simulator's reader.

Every vector marked "manual" is copied from the RC-233 manual (§10 SUM, EE, EL, ER, §12 /CO);
see docs/manual-notes.md ("Framing and the reply stream") for the decisions the other vectors hold.
"""

from __future__ import annotations

from dataclasses import fields
from itertools import product

import pytest
from hypothesis import given
from hypothesis import strategies as st

from gateway.errors import ParameterError
from gateway.protocol.command_reader import CommandFrame, CommandReader, RawText, Stray
from gateway.protocol.command_text import REGISTRY
from gateway.protocol.framing import (
    BODY_NUMBERS,
    EEPROM_DONE,
    MAX_FRAME,
    POWER_ON,
    SWITCH_FIELDS,
    TIMER_UP,
    Framing,
    FramingSwitch,
    Series,
    checksum,
    encode_ack,
    encode_command,
    encode_data,
    encode_not_accepted,
    encode_program_error,
    encode_program_message,
    encode_unsolicited,
    framing_switch,
    from_wire,
    to_wire,
)

SUM = Framing(checksum=True)
ECHO = Framing(echo=True)
EL = Framing(cr_after_ack=True)
ER = Framing(error_mark=True)
ALL_FRAMINGS = [
    Framing(e, c, r, s) for e, c, r, s in product((False, True), repeat=4) if not (e and s)
]
KANA = "".join(chr(c) for c in range(0xFF61, 0xFFA0))
TEXT = st.text(
    st.sampled_from(
        [chr(c) for c in range(0x20, 0x7F) if chr(c) not in "$#"] + list(KANA[:5]) + ["¥"]
    ),
    max_size=30,
)

# ------------------------------------------------------------------ wire text


def test_ascii_passes_as_is() -> None:
    text = "".join(chr(c) for c in range(0x80))
    assert to_wire(text) == bytes(range(0x80))
    assert from_wire(bytes(range(0x80))) == text


def test_half_width_katakana_is_jis_x_0201() -> None:
    assert to_wire(KANA) == bytes(range(0xA1, 0xE0))
    assert from_wire(bytes(range(0xA1, 0xE0))) == KANA
    assert to_wire("G\uff71") == b"G\xb1"  # a label ｱ (manual-notes: labels)


def test_yen_is_0x5c_and_comes_back_as_backslash() -> None:
    assert to_wire("¥") == b"\\"
    assert from_wire(to_wire("¥")) == "\\"


@pytest.mark.parametrize("char", ["é", "€", "ア", "\u3000", "\uff60", "\uffa0"])
def test_other_characters_are_refused(char: str) -> None:
    with pytest.raises(ValueError, match="no single-byte code"):
        to_wire("A" + char)


def test_other_high_bytes_decode_to_replacement() -> None:
    high = bytes([0x80, 0x9F, 0xA0, 0xE0, 0xFF])
    assert from_wire(high) == "\ufffd" * 5


@given(st.binary())
def test_from_wire_never_raises_and_keeps_length(data: bytes) -> None:
    assert len(from_wire(data)) == len(data)


@given(st.text(st.sampled_from([chr(c) for c in range(0x80)] + list(KANA))))
def test_wire_text_round_trips(text: str) -> None:
    assert from_wire(to_wire(text)) == text


# ------------------------------------------------------------------ checksum (§10 SUM)


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        (b"$1", b"55"),  # manual: 36+49 = 85 = 55h
        (b"$16", b"8B"),  # manual: 139 = 8Bh
        (b"$1A01300", b"8A"),  # manual: 394 = 18Ah
        (b">$10", b"C3"),  # manual: 62+36+49+48 = 195 = C3h
        (b">$108", b"FB"),  # manual: 251 = FBh
        (b">$11", b"C4"),  # manual: SUM query reply of body 1
        (b"$1SUM", b"4A"),  # 330 = 14Ah
        (b">", b"3E"),  # the EL1 + SUM1 '>' reply
        (b"\x0f", b"0F"),  # always two digits: 10Fh -> '0F', not 'F'
        (b"\xff\x10", b"0F"),
        (b"", b"00"),
    ],
)
def test_checksum(body: bytes, expected: bytes) -> None:
    assert checksum(body) == expected


# ------------------------------------------------------------------ command frames (§9-1)


@pytest.mark.parametrize(
    ("text", "plain", "summed"),
    [
        ("", b"$1\r", b"$155\r"),  # manual
        ("6", b"$16\r", b"$168B\r"),  # manual
        ("A01300", b"$1A01300\r", b"$1A013008A\r"),  # manual
    ],
)
def test_encode_command_manual_vectors(text: str, plain: bytes, summed: bytes) -> None:
    assert encode_command("1", text) == plain
    assert encode_command("1", text, framing=SUM) == summed


def test_encode_command_other_switches_do_not_change_the_command() -> None:
    for framing in ALL_FRAMINGS:
        expected = b"$1A01300" + (b"8A" if framing.checksum else b"") + b"\r"
        assert encode_command("1", "A01300", framing=framing) == expected


def test_encode_command_hash_series() -> None:
    assert encode_command("E", "6", series=Series.HASH) == b"#E6\r"
    assert (
        encode_command("1", "", series=Series.HASH, framing=SUM) == b"#1" + checksum(b"#1") + b"\r"
    )


def test_encode_command_writes_labels_in_jis() -> None:
    assert encode_command("0", "G\uff71") == b"$0G\xb1\r"


@pytest.mark.parametrize("body", ["F", "10", "", "a", "G", " "])
def test_encode_command_refuses_body_numbers(body: str) -> None:
    with pytest.raises(ParameterError) as info:
        encode_command(body, "6")
    assert info.value.field == "body"


@pytest.mark.parametrize("text", ["6$", "$16", "A#1", "6\r", "6\n", "OH\r\n"])
def test_encode_command_refuses_marks_and_line_ends(text: str) -> None:
    with pytest.raises(ParameterError) as info:
        encode_command("1", text)
    assert info.value.field == "text"


def test_encode_command_refuses_unencodable_text() -> None:
    with pytest.raises(ParameterError) as info:
        encode_command("1", "COé")
    assert info.value.field == "text"
    assert "ASCII" in info.value.rule


def test_body_numbers() -> None:
    assert BODY_NUMBERS == "0123456789ABCDE"
    assert all(encode_command(b, "").startswith(b"$" + b.encode()) for b in BODY_NUMBERS)


# ------------------------------------------------------------------ framing switches


def test_power_on_framing_is_all_off() -> None:
    assert Framing() == POWER_ON == Framing(False, False, False, False)


def test_echo_and_checksum_cannot_be_on_together() -> None:
    with pytest.raises(ValueError, match="EE1 and SUM1"):
        Framing(echo=True, checksum=True)


@pytest.mark.parametrize(
    ("before", "text", "expected"),
    [
        # EE, ER, SUM: the command's own reply keeps the old framing (§10 EE: EE1 -> '>',
        # EE0 -> its echo).
        (POWER_ON, "EE1", FramingSwitch(POWER_ON, ECHO)),
        (ECHO, "EE0", FramingSwitch(ECHO, POWER_ON)),
        (POWER_ON, "EE0", FramingSwitch(POWER_ON, POWER_ON)),
        (POWER_ON, "ER1", FramingSwitch(POWER_ON, ER)),
        (ER, "ER0", FramingSwitch(ER, POWER_ON)),
        (POWER_ON, "SUM1", FramingSwitch(POWER_ON, SUM)),
        (SUM, "SUM0", FramingSwitch(SUM, POWER_ON)),
        (EL, "SUM1", FramingSwitch(EL, Framing(cr_after_ack=True, checksum=True))),
        # EL: the reply to EL1 is already '>' CR, the reply to EL0 '>' (§10 EL)
        (POWER_ON, "EL1", FramingSwitch(EL, EL)),
        (EL, "EL0", FramingSwitch(POWER_ON, POWER_ON)),
        # the manual forbids EE with SUM: refused, nothing changes
        (SUM, "EE1", FramingSwitch(SUM, SUM, refused=True)),
        (ECHO, "SUM1", FramingSwitch(ECHO, ECHO, refused=True)),
        # switching off is always allowed
        (SUM, "EE0", FramingSwitch(SUM, SUM)),
        # not a switch setting
        (EL, "EL", FramingSwitch(EL, EL)),
        (EL, "SUM", FramingSwitch(EL, EL)),
        (EL, "EE2", FramingSwitch(EL, EL)),
        (EL, "6", FramingSwitch(EL, EL)),
        (EL, "", FramingSwitch(EL, EL)),
        (EL, "OH1", FramingSwitch(EL, EL)),
    ],
)
def test_framing_switch(before: Framing, text: str, expected: FramingSwitch) -> None:
    assert framing_switch(before, text) == expected


#: §10's names of the four switches (the list of the settings DW stores, and each command's
#: 機能 line); what each one's "1" does to the bytes is pinned below with §10's own examples.
MANUAL_SWITCHES = {
    "EE": "エコーバック機能",
    "EL": "キャリッジ・リターン追加機能",
    "ER": "エラー表示機能",
    "SUM": "サム・チェック機能",
}


def test_the_switch_table_names_the_manuals_four_switches() -> None:
    assert set(SWITCH_FIELDS) == set(MANUAL_SWITCHES)
    assert sorted(SWITCH_FIELDS.values()) == sorted(f.name for f in fields(Framing))
    # Each switch of the table is the catalog's: its query, and its two settings, which the
    # catalog marks as switching the framing (and no other form is so marked).
    switching = {e.key for e in REGISTRY.entries if e.form.switches_framing}
    assert switching == {f"{name}{digit}" for name in SWITCH_FIELDS for digit in "01"}
    for name in SWITCH_FIELDS:
        assert not REGISTRY.form(name).switches_framing  # the query reads it


def _on(name: str) -> Framing:
    """The framing after ``{name}1`` from the factory setting, through the table."""
    return framing_switch(POWER_ON, f"{name}1").after


def test_each_switch_turns_on_what_the_manual_describes() -> None:
    # §10 EE: '$1' CR is answered '$1' CR '$10' CR; '$10' CR with its echo alone.
    assert encode_data("1", "0", _on("EE"), sent=b"$1\r") == b"$1\r$10\r"
    assert encode_ack(_on("EE"), sent=b"$10\r") == b"$10\r"
    # §10 EL: '$10' CR is answered '>' CR; a query's reply is unchanged.
    assert encode_ack(_on("EL"), sent=b"$10\r") == b">\r"
    assert encode_data("1", "0", _on("EL"), sent=b"$1\r") == b">$10\r"
    # §10 ER: a command error is answered '>@'; an accepted command '>' as before.
    assert encode_ack(_on("ER"), sent=b"$1G\r", error=True) == b">@"
    assert encode_ack(_on("ER"), sent=b"$10\r") == b">"
    # §10 SUM: '$16' CR goes out as '$168B' CR; '>$10' CR comes back as '>$10C3' CR.
    assert encode_command("1", "6", framing=_on("SUM")) == b"$168B\r"
    assert encode_data("1", "0", _on("SUM"), sent=b"$155\r") == b">$10C3\r"
    # Each switch turns on its own field and no other (the four are independent).
    assert {name: _on(name) for name in SWITCH_FIELDS} == {
        name: Framing(**{field_name: True}) for name, field_name in SWITCH_FIELDS.items()
    }


# ------------------------------------------------------------------ device replies


@pytest.mark.parametrize(
    ("sent", "data", "with_echo", "without"),
    [
        # manual, §10 EE table
        (b"$1\r", "0", b"$1\r$10\r", b">$10\r"),
        (b"$10\r", None, b"$10\r", b">"),
        (b"$16\r", "00000300", b"$16\r$100000300\r", b">$100000300\r"),
        (b"$1B01\r", None, b"$1B01\r", b">"),  # as printed
        (b"$1B001\r", None, b"$1B001\r", b">"),  # with a valid position number
        # manual, §10 EE form III: the EE query itself
        (b"$1EE\r", "1", b"$1EE\r$11\r", None),
        (b"$1EE\r", "0", None, b">$10\r"),
    ],
)
def test_echo_table(sent: bytes, data: str | None, with_echo: bytes, without: bytes) -> None:
    for framing, expected in ((ECHO, with_echo), (POWER_ON, without)):
        if expected is None:
            continue
        if data is None:
            assert encode_ack(framing, sent=sent) == expected
        else:
            assert encode_data("1", data, framing, sent=sent) == expected


def test_ee0_is_answered_with_its_echo() -> None:
    # manual §10 EE form II: '$' B# 'EE0' CR while echo is on; '>' when it is already off
    switch = framing_switch(ECHO, "EE0")
    assert encode_ack(switch.reply, sent=b"$1EE0\r") == b"$1EE0\r"
    assert encode_ack(framing_switch(POWER_ON, "EE0").reply, sent=b"$1EE0\r") == b">"
    assert encode_ack(framing_switch(POWER_ON, "EE1").reply, sent=b"$1EE1\r") == b">"


@pytest.mark.parametrize(
    ("sent", "data", "expected"),
    [
        # manual, §10 EL table: general replies get CR, query replies do not change
        (b"$10\r", None, b">\r"),
        (b"$1\r", "0", b">$10\r"),
        (b"$1B01\r", None, b">\r"),
        (b"$16\r", "00000300", b">$100000300\r"),
        (b"$1EL1\r", None, b">\r"),
    ],
)
def test_el_table(sent: bytes, data: str | None, expected: bytes) -> None:
    if data is None:
        assert encode_ack(EL, sent=sent) == expected
    else:
        assert encode_data("1", data, EL, sent=sent) == expected
    assert encode_ack(framing_switch(EL, "EL0").reply, sent=b"$1EL0\r") == b">"


def test_error_mark() -> None:
    # manual §10 ER: '>@' without CR; CR only with EL1
    assert encode_ack(ER, sent=b"$1X\r", error=True) == b">@"
    assert encode_ack(Framing(cr_after_ack=True, error_mark=True), sent=b"", error=True) == b">@\r"
    assert encode_ack(POWER_ON, sent=b"$1X\r", error=True) == b">"  # ER0: plain '>'
    assert encode_ack(ER, sent=b"$1X\r") == b">"
    echo_er = Framing(echo=True, error_mark=True)
    assert encode_ack(echo_er, sent=b"$1X\r", error=True) == b"$1X\r@"
    echo_el_er = Framing(echo=True, cr_after_ack=True, error_mark=True)
    assert encode_ack(echo_el_er, sent=b"$1X\r", error=True) == b"$1X\r@\r"


def test_echo_with_el_ends_with_cr() -> None:
    # decision: the normal reply '>' CR minus '>' is CR
    assert encode_ack(Framing(echo=True, cr_after_ack=True), sent=b"$10\r") == b"$10\r\r"


def test_checksum_replies() -> None:
    # manual §10 SUM receive examples and the SUM query
    assert encode_data("1", "0", SUM, sent=b"$155\r") == b">$10C3\r"
    assert encode_data("1", "08", SUM, sent=b"") == b">$108FB\r"
    assert encode_data("1", "1", SUM, sent=b"$1SUM4A\r") == b">$11C4\r"
    # one-character replies carry no checksum; with EL1 '>' becomes '>3E' CR
    assert encode_ack(SUM, sent=b"$155\r") == b">"
    assert encode_not_accepted() == b"?"
    sum_el = Framing(cr_after_ack=True, checksum=True)
    assert encode_ack(sum_el, sent=b"$155\r") == b">3E\r"
    assert encode_ack(Framing(error_mark=True, checksum=True), sent=b"", error=True) == b">@"
    sum_el_er = Framing(cr_after_ack=True, error_mark=True, checksum=True)
    assert encode_ack(sum_el_er, sent=b"", error=True) == b">@7E\r"


def test_data_reply_series_and_text() -> None:
    assert encode_data("3", "1", POWER_ON, series=Series.HASH, sent=b"") == b">#31\r"
    echo = encode_data("3", "1", ECHO, series=Series.HASH, sent=b"#3EE\r")
    assert echo == b"#3EE\r#31\r"
    version = "RC-233 Ver 1.19 by RORZE (01-02-03)"
    assert encode_data("0", version, POWER_ON, sent=b"") == b">$0" + version.encode() + b"\r"
    with pytest.raises(ParameterError):
        encode_data("F", "0", POWER_ON, sent=b"")


def test_unsolicited_messages() -> None:
    assert encode_unsolicited("1", EEPROM_DONE, POWER_ON) == b"$1*\r"
    assert encode_unsolicited("1", TIMER_UP, EL) == b"$1T\r"
    assert encode_unsolicited("1", EEPROM_DONE, SUM) == b"$1*" + checksum(b"$1*") + b"\r"
    assert encode_unsolicited("2", "00000300", ECHO) == b"$200000300\r"  # no echo: no command
    assert encode_unsolicited("E", TIMER_UP, POWER_ON, series=Series.HASH) == b"#ET\r"
    with pytest.raises(ParameterError):
        encode_unsolicited("X", TIMER_UP, POWER_ON)


def test_program_messages() -> None:
    # manual §12 /CO: '/CO123ABC*+-%' sends '>123ABC*+-%' CR
    assert encode_program_message("123ABC*+-%", POWER_ON) == b">123ABC*+-%\r"
    assert encode_program_message("OK", SUM) == b">OK" + checksum(b">OK") + b"\r"
    # §12 /CC: '>' '$' B# CT nnnnn CR
    assert encode_program_message("$1100042", POWER_ON) == b">$1100042\r"
    assert encode_program_error() == b"@"


# ------------------------------------------------------------------ command reader


def frame(text: str, raw: bytes, *, body: str = "1", ok: bool | None = None) -> CommandFrame:
    return CommandFrame(Series(chr(raw[0])), body, text, ok, raw)


def test_reader_reads_frames() -> None:
    reader = CommandReader()
    assert reader.feed(b"$1\r$16\r#E9\r") == [
        frame("", b"$1\r"),
        frame("6", b"$16\r"),
        frame("9", b"#E9\r", body="E"),
    ]


def test_reader_frames_split_across_chunks() -> None:
    reader = CommandReader()
    assert reader.feed(b"$1A0") == []
    assert reader.feed(b"1300") == []
    assert reader.feed(b"\r") == [frame("A01300", b"$1A01300\r")]
    assert reader.next_event() is None


def test_reader_decodes_labels() -> None:
    assert CommandReader().feed(b"$1G\xb1\r") == [frame("G\uff71", b"$1G\xb1\r")]


def test_reader_keeps_body_f_and_unknown_bodies() -> None:
    assert CommandReader().feed(b"$F6\r$Z\r") == [
        frame("6", b"$F6\r", body="F"),
        frame("", b"$Z\r", body="Z"),
    ]


@pytest.mark.parametrize(
    ("raw", "text", "ok"),
    [
        (b"$155\r", "", True),  # manual
        (b"$168B\r", "6", True),  # manual
        (b"$1A013008A\r", "A01300", True),  # manual
        (b"$1SUM4A\r", "SUM", True),
        (b"$156\r", "", False),
        (b"$168b\r", "6", False),  # the device's digits are upper case
        (b"$16\r", "6", False),  # too short to carry a checksum
        (b"$1\r", "", False),
    ],
)
def test_reader_checks_checksums(raw: bytes, text: str, ok: bool) -> None:
    reader = CommandReader()
    reader.set_checksum("1", True)
    assert reader.feed(raw) == [frame(text, raw, ok=ok)]


def test_reader_checksum_is_per_body_and_series() -> None:
    reader = CommandReader()
    reader.set_checksum("1", True)
    assert reader.feed(b"$255\r#155\r") == [
        frame("55", b"$255\r", body="2"),
        frame("55", b"#155\r"),
    ]
    reader.set_checksum("1", True, series=Series.HASH)
    reader.set_checksum("1", False)
    assert reader.feed(b"$155\r#1" + checksum(b"#1") + b"\r") == [
        frame("55", b"$155\r"),
        frame("", b"#1" + checksum(b"#1") + b"\r", ok=True),
    ]


def test_reader_reports_stray_bytes() -> None:
    reader = CommandReader()
    assert reader.feed(b"/") == [Stray(b"/")]
    assert reader.feed(b"$10\r\n") == [frame("0", b"$10\r"), Stray(b"\n")]
    assert reader.feed(b"$\r") == [Stray(b"$\r")]
    assert reader.feed(b"ab\rcd$1\r") == [Stray(b"ab\r"), Stray(b"cd"), frame("", b"$1\r")]
    assert reader.feed(b"\r") == [Stray(b"\r")]


def test_reader_restarts_on_a_start_mark() -> None:
    reader = CommandReader()
    assert reader.feed(b"$1OH5$10\r") == [Stray(b"$1OH5"), frame("0", b"$10\r")]
    assert reader.feed(b"#1$2\r") == [Stray(b"#1"), frame("", b"$2\r", body="2")]


def test_reader_drops_overlong_frames() -> None:
    reader = CommandReader()
    long = b"$1" + b"A" * MAX_FRAME
    events = reader.feed(long + b"\r$1\r")
    assert events == [
        Stray(long[: MAX_FRAME + 1]),
        Stray(long[MAX_FRAME + 1 :] + b"\r"),
        frame("", b"$1\r"),
    ]


def test_reader_program_text_after_i() -> None:
    # manual §13-2 example 3: the program comes in pieces, only the last one with CR
    reader = CommandReader()
    assert reader.feed(b"$1I\r") == [frame("I", b"$1I\r")]
    reader.begin_raw("1")
    assert reader.feed(b"/E0/OC30/OH8000/OL1000/OS300/OX60/A00130000/CS1,10") == []
    events = reader.feed(b"/0//B001//1//CD1/JC1+1/J-7/END\r$1IW\r")
    program = "/E0/OC30/OH8000/OL1000/OS300/OX60/A00130000/CS1,10/0//B001//1//CD1/JC1+1/J-7/END"
    assert events == [
        RawText(Series.DOLLAR, "1", program, program.encode() + b"\r", True),
        frame("IW", b"$1IW\r"),
    ]


def test_reader_program_text_cut_by_a_start_mark() -> None:
    reader = CommandReader()
    reader.begin_raw("2", series=Series.HASH)
    assert reader.feed(b"/COAB\xb1#26\r") == [
        RawText(Series.HASH, "2", "/COAB\uff71", b"/COAB\xb1", False),
        frame("6", b"#26\r", body="2"),
    ]


def test_reader_pull_lets_a_frame_change_how_the_next_is_read() -> None:
    chunk = b"$1SUM1\r$155\r$1I\r/G1/END\r"
    assert CommandReader().feed(chunk)[1] == frame("55", b"$155\r")  # read too early

    reader = CommandReader()
    reader.push(chunk)
    assert reader.next_event() == frame("SUM1", b"$1SUM1\r")
    reader.set_checksum("1", True)
    assert reader.next_event() == frame("", b"$155\r", ok=True)
    assert reader.next_event() == frame("I", b"$1I\r", ok=False)
    reader.begin_raw("1")
    assert reader.next_event() == RawText(Series.DOLLAR, "1", "/G1/END", b"/G1/END\r", True)
    assert reader.next_event() is None


def test_reader_begin_raw_after_reading_past_the_i_frame() -> None:
    reader = CommandReader()
    assert reader.feed(b"$1I\r$1") == [frame("I", b"$1I\r")]
    reader.begin_raw("1")
    assert reader.feed(b"/END\r") == [
        Stray(b"$1"),
        RawText(Series.DOLLAR, "1", "/END", b"/END\r", True),
    ]


@given(
    st.sampled_from(BODY_NUMBERS),
    TEXT,
    st.sampled_from(list(Series)),
    st.booleans(),
    st.lists(st.integers(1, 40), max_size=5),
)
def test_encoded_commands_read_back(
    body: str, text: str, series: Series, summed: bool, cuts: list[int]
) -> None:
    framing = Framing(checksum=summed)
    wire = encode_command(body, text, series=series, framing=framing)
    reader = CommandReader()
    reader.set_checksum(body, summed, series=series)
    events = []
    for piece in _split(wire, cuts):
        events += reader.feed(piece)
    decoded = text.replace("¥", "\\")
    assert events == [CommandFrame(series, body, decoded, True if summed else None, wire)]


@given(
    st.lists(
        st.one_of(
            st.binary(max_size=20),
            st.sampled_from([b"$", b"#", b"\r", b"$1", b"$155\r", b"/"]),
            st.just(b"$" + b"A" * (MAX_FRAME + 2)),
            st.sampled_from(["raw", "sum", "pull"]),
        ),
        max_size=30,
    )
)
def test_reader_never_raises(actions: list[bytes | str]) -> None:
    reader = CommandReader()
    total = 0
    for action in actions:
        if action == "raw":
            reader.begin_raw("1")
        elif action == "sum":
            reader.set_checksum("1", True)
        elif action == "pull":
            reader.next_event()
        else:
            assert isinstance(action, bytes)
            events = reader.feed(action)
            total += sum(len(event.raw) for event in events)
    assert total <= sum(len(a) for a in actions if isinstance(a, bytes))


def _split(data: bytes, cuts: list[int]) -> list[bytes]:
    pieces, pos = [], 0
    for cut in cuts:
        pieces.append(data[pos : pos + cut])
        pos += cut
    pieces.append(data[pos:])
    return pieces
