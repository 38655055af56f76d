"""The host's reply parser: manual vectors, every framing combination, robustness properties.

Vectors marked "manual" are copied from the RC-233 manual (§9-2, §10 EE, EL, ER, SUM, §12);
docs/manual-notes.md ("Framing and the reply stream") has the decisions the others hold.
"""

from __future__ import annotations

from dataclasses import replace
from itertools import product

import pytest
from hypothesis import given
from hypothesis import strategies as st

from gateway.protocol.framing import (
    EEPROM_DONE,
    POWER_ON,
    TIMER_UP,
    Framing,
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
)
from gateway.protocol.reply_parser import (
    MAX_LINE,
    Accepted,
    ChecksumMismatch,
    CommandRejected,
    DataReply,
    Expectation,
    Garbled,
    NotAccepted,
    ReplyEvent,
    ReplyParser,
    Unsolicited,
    UnsolicitedKind,
)

DOLLAR, HASH = Series.DOLLAR, Series.HASH
EEPROM, TIMER, PROGRAM = (
    UnsolicitedKind.EEPROM_DONE,
    UnsolicitedKind.TIMER_UP,
    UnsolicitedKind.PROGRAM_OUTPUT,
)
SUM = Framing(checksum=True)
ECHO = Framing(echo=True)
EL = Framing(cr_after_ack=True)
ER = Framing(error_mark=True)
EL_ER = Framing(cr_after_ack=True, error_mark=True)
ALL_FRAMINGS = [
    Framing(e, c, r, s) for e, c, r, s in product((False, True), repeat=4) if not (e and s)
]


def parser_for(
    framing: Framing = POWER_ON,
    sent: bytes | None = None,
    has_data: bool = False,
    *,
    series: Series = DOLLAR,
    body: str = "1",
) -> ReplyParser:
    parser = ReplyParser(framing, series)
    if sent is not None:
        parser.expect(body, sent, has_data)
    return parser


def run(parser: ReplyParser, *chunks: bytes, quiet: bool = False) -> list[ReplyEvent]:
    events: list[ReplyEvent] = []
    for chunk in chunks:
        events += parser.feed(chunk)
    if quiet:
        events += parser.line_quiet()
    return events


def data(raw: bytes, value: str, body: str = "1") -> DataReply:
    return DataReply(raw=raw, is_reply=True, body=body, data=value)


def unsolicited(
    raw: bytes,
    kind: UnsolicitedKind,
    value: str,
    body: str | None = "1",
    series: Series | None = DOLLAR,
) -> Unsolicited:
    return Unsolicited(raw=raw, kind=kind, series=series, body=body, data=value)


EEPROM_1 = unsolicited(b"$1*\r", EEPROM, "*")
TIMER_1 = unsolicited(b"$1T\r", TIMER, "T")

# ------------------------------------------------------------------ §9-2 basic replies


def test_general_reply_is_accepted_at_once() -> None:
    parser = parser_for(sent=b"$10\r")
    assert parser.feed(b">") == [Accepted(raw=b">", is_reply=True)]
    assert parser.pending is None


def test_query_reply() -> None:
    parser = parser_for(sent=b"$1\r", has_data=True)
    assert run(parser, b">$1", b"0", b"\r") == [data(b">$10\r", "0")]
    assert parser.pending is None


def test_question_mark_is_not_accepted() -> None:
    parser = parser_for(sent=b"$1\r", has_data=True)
    assert parser.feed(b"?") == [NotAccepted(raw=b"?", is_reply=True)]
    assert parser.pending is None


def test_query_answered_with_a_bare_ack_waits_for_the_next_byte() -> None:
    # a refused query is answered '>' (command error with ER0): only silence tells
    parser = parser_for(sent=b"$1CLM2\r", has_data=True)
    assert parser.feed(b">") == []
    assert parser.line_quiet() == [Accepted(raw=b">", is_reply=True)]
    parser.expect("1", b"$1CLM2\r", True)
    assert parser.feed(b">?") == [Accepted(raw=b">", is_reply=True), NotAccepted(raw=b"?")]


def test_version_reply_keeps_its_text() -> None:
    parser = parser_for(sent=b"$0V\r", has_data=True, body="0")
    reply = b">$0RC-233 Ver 1.19 by RORZE (01-02-03)\r"
    assert parser.feed(reply) == [data(reply, "RC-233 Ver 1.19 by RORZE (01-02-03)", "0")]


def test_program_text_reply_may_hold_marks_of_labels() -> None:
    # IR returns the program; labels may be '>', '?', '@' and half-width katakana
    parser = parser_for(sent=b"$1IR\r", has_data=True)
    reply = b">$1/G>/G?/G@/G\xb1/END\r"
    assert parser.feed(reply) == [data(reply, "/G>/G?/G@/G\uff71/END")]


# ------------------------------------------------------------------ §10 SUM


@pytest.mark.parametrize(
    ("reply", "value"),
    [(b">$10C3\r", "0"), (b">$108FB\r", "08"), (b">$11C4\r", "1")],  # manual
)
def test_checksum_replies_valid(reply: bytes, value: str) -> None:
    parser = parser_for(SUM, b"$155\r", True)
    assert parser.feed(reply) == [data(reply, value)]


def test_checksum_reply_mismatch() -> None:
    parser = parser_for(SUM, b"$155\r", True)  # manual: '>$10C5' CR is not trustworthy
    assert parser.feed(b">$10C5\r") == [ChecksumMismatch(raw=b">$10C5\r", is_reply=True)]
    assert parser.pending is None


def test_checksum_one_character_replies_carry_none() -> None:
    parser = parser_for(SUM, b"$1OH1000" + checksum(b"$1OH1000") + b"\r")
    assert parser.feed(b">") == [Accepted(raw=b">", is_reply=True)]
    parser.expect("1", b"$156\r", True)
    assert parser.feed(b"?") == [NotAccepted(raw=b"?", is_reply=True)]


def test_checksum_with_el() -> None:
    sum_el = Framing(cr_after_ack=True, checksum=True)
    parser = parser_for(sum_el, b"$10" + checksum(b"$10") + b"\r")
    assert parser.feed(b">3E\r") == [Accepted(raw=b">3E\r", is_reply=True)]
    parser.expect("1", b"$10\r", False)
    assert parser.feed(b">\r") == [ChecksumMismatch(raw=b">\r", is_reply=True)]
    parser.expect("1", b"$10\r", False)
    assert parser.feed(b">3F\r") == [ChecksumMismatch(raw=b">3F\r", is_reply=True)]


def test_checksum_of_unsolicited_messages() -> None:
    parser = parser_for(SUM, b"$155\r", True)
    summed = b"$1*" + checksum(b"$1*") + b"\r"
    assert parser.feed(summed) == [unsolicited(summed, EEPROM, "*")]
    # accepted without a checksum too: the manual does not say whether they carry one
    assert parser.feed(b"$1*\r$1T\r") == [EEPROM_1, TIMER_1]
    assert parser.feed(b"$1*00\r") == [ChecksumMismatch(raw=b"$1*00\r")]
    assert parser.pending is not None
    assert parser.feed(b">$10C3\r") == [data(b">$10C3\r", "0")]


def test_sum1_reply_uses_the_old_framing() -> None:
    switch = framing_switch(EL, "SUM1")
    parser = ReplyParser(EL)
    parser.expect("1", b"$1SUM1\r", False, framing=switch.reply)
    assert parser.feed(b">\r") == [Accepted(raw=b">\r", is_reply=True)]
    parser.configure(framing=switch.after)
    assert parser.framing == Framing(cr_after_ack=True, checksum=True)
    parser.expect("1", b"$1SUM4A\r", True)
    assert parser.feed(b">$11C4\r") == [data(b">$11C4\r", "1")]


# ------------------------------------------------------------------ §10 EE


@pytest.mark.parametrize(
    ("sent", "has_data", "reply", "expected"),
    [
        # manual, §10 EE table
        (b"$1\r", True, b"$1\r$10\r", data(b"$1\r$10\r", "0")),
        (b"$10\r", False, b"$10\r", Accepted(raw=b"$10\r", is_reply=True)),
        (b"$16\r", True, b"$16\r$100000300\r", data(b"$16\r$100000300\r", "00000300")),
        (b"$1B01\r", False, b"$1B01\r", Accepted(raw=b"$1B01\r", is_reply=True)),
        (b"$1B001\r", False, b"$1B001\r", Accepted(raw=b"$1B001\r", is_reply=True)),
        # manual, §10 EE forms II and III
        (b"$1EE0\r", False, b"$1EE0\r", Accepted(raw=b"$1EE0\r", is_reply=True)),
        (b"$1EE\r", True, b"$1EE\r$11\r", data(b"$1EE\r$11\r", "1")),
    ],
)
def test_echo_table(sent: bytes, has_data: bool, reply: bytes, expected: ReplyEvent) -> None:
    parser = parser_for(ECHO, sent, has_data)
    assert parser.feed(reply) == [expected]
    assert parser.pending is None


def test_echo_table_split_byte_by_byte() -> None:
    parser = parser_for(ECHO, b"$16\r", True)
    reply = b"$16\r$100000300\r"
    assert run(parser, *(bytes([b]) for b in reply)) == [data(reply, "00000300")]


@pytest.mark.parametrize(
    ("sent", "reply", "value"),
    [(b"$1EE\r", b">$10\r", "0"), (b"$1\r", b">$10\r", "0")],  # manual, echo off
)
def test_echo_off_forms(sent: bytes, reply: bytes, value: str) -> None:
    assert parser_for(POWER_ON, sent, True).feed(reply) == [data(reply, value)]


def test_ee1_is_answered_with_a_bare_ack() -> None:
    switch = framing_switch(POWER_ON, "EE1")
    parser = ReplyParser()
    parser.expect("1", b"$1EE1\r", False, framing=switch.reply)
    assert parser.feed(b">") == [Accepted(raw=b">", is_reply=True)]


def test_changed_echo_is_garbled() -> None:
    parser = parser_for(ECHO, b"$16\r", True)
    assert parser.feed(b"$17\r") == [Garbled(raw=b"$17\r", is_reply=True)]
    assert parser.pending is None
    # the response part that follows is no longer anybody's reply
    assert parser.feed(b"$100000300\r") == [unsolicited(b"$100000300\r", PROGRAM, "00000300")]


def test_echo_cut_short_is_garbled() -> None:
    parser = parser_for(ECHO, b"$16\r", True)
    assert parser.feed(b"$1") == []
    assert parser.line_quiet() == [Garbled(raw=b"$1", is_reply=True)]
    parser.expect("1", b"$16\r", True)
    # a lost CR: the next '$' restarts, the damaged echo ends the expectation
    assert parser.feed(b"$16$100000300\r") == [
        Garbled(raw=b"$16", is_reply=True),
        unsolicited(b"$100000300\r", PROGRAM, "00000300"),
    ]


def test_echo_response_cut_short() -> None:
    parser = parser_for(ECHO, b"$16\r", True)
    assert parser.feed(b"$16\r$1000") == []
    assert parser.line_quiet() == [Garbled(raw=b"$16\r$1000", is_reply=True)]


def test_echo_ignores_other_controllers_and_unsolicited_messages() -> None:
    parser = parser_for(ECHO, b"$16\r", True)
    assert parser.feed(b"$1T\r$2OK\r$16\r$2*\r$100000300\r") == [
        TIMER_1,
        unsolicited(b"$2OK\r", PROGRAM, "OK", "2"),
        unsolicited(b"$2*\r", EEPROM, "*", "2"),
        data(b"$16\r$100000300\r", "00000300"),
    ]


def test_echo_of_a_timer_command_is_not_a_time_up() -> None:
    parser = parser_for(ECHO, b"$1T\r", False)
    assert parser.feed(b"$1T\r") == [Accepted(raw=b"$1T\r", is_reply=True)]


def test_echo_then_bare_response_of_a_refused_query() -> None:
    parser = parser_for(ECHO, b"$1CLM2\r", True)
    assert parser.feed(b"$1CLM2\r") == []
    assert parser.line_quiet() == [Accepted(raw=b"$1CLM2\r", is_reply=True)]
    parser.expect("1", b"$1CLM2\r", True)
    assert parser.feed(b"$1CLM2\r?") == [
        Accepted(raw=b"$1CLM2\r", is_reply=True),
        NotAccepted(raw=b"?"),
    ]


def test_echo_expected_but_a_question_mark_comes() -> None:
    parser = parser_for(ECHO, b"$16\r", True)
    assert parser.feed(b"?") == [NotAccepted(raw=b"?", is_reply=True)]


def test_echo_expected_but_a_bare_ack_comes() -> None:
    # '>' is never the reply while echo is on: a late reply, not this command's
    parser = parser_for(ECHO, b"$10\r", False)
    assert run(parser, b">", quiet=True) == [Accepted(raw=b">")]
    assert parser.pending is not None


@pytest.mark.parametrize(
    ("framing", "reply", "extra"),
    [
        # decision: EE1 + EL1 general reply is echo + CR; echo alone is accepted as well
        (Framing(echo=True, cr_after_ack=True), b"$10\r\r", b""),
        (Framing(echo=True, cr_after_ack=True), b"$10\r", b"?"),
        (Framing(echo=True, error_mark=True), b"$10\r", b">"),
    ],
)
def test_echo_with_el_or_er_general_reply(framing: Framing, reply: bytes, extra: bytes) -> None:
    parser = parser_for(framing, b"$10\r")
    events = run(parser, reply + extra)
    assert events[0] == Accepted(raw=reply, is_reply=True)
    assert parser.pending is None


@pytest.mark.parametrize(
    ("framing", "reply", "quiet"),
    [
        (Framing(echo=True, error_mark=True), b"$1X\r@", False),
        (Framing(echo=True, cr_after_ack=True, error_mark=True), b"$1X\r@\r", False),
        (Framing(echo=True, cr_after_ack=True, error_mark=True), b"$1X\r@", True),
        (Framing(echo=True), b"$1X\r@", False),  # '@' right after the echo: the error mark
    ],
)
def test_echo_with_error_mark(framing: Framing, reply: bytes, quiet: bool) -> None:
    parser = parser_for(framing, b"$1X\r", True)
    assert run(parser, reply, quiet=quiet) == [CommandRejected(raw=reply, is_reply=True)]


def test_echo_error_mark_without_its_cr() -> None:
    parser = parser_for(Framing(echo=True, cr_after_ack=True, error_mark=True), b"$1X\r")
    assert parser.feed(b"$1X\r@$1*\r") == [
        CommandRejected(raw=b"$1X\r@", is_reply=True),
        EEPROM_1,
    ]


# ------------------------------------------------------------------ §10 EL, ER


@pytest.mark.parametrize(
    ("sent", "has_data", "reply", "expected"),
    [
        # manual, §10 EL table
        (b"$10\r", False, b">\r", Accepted(raw=b">\r", is_reply=True)),
        (b"$1\r", True, b">$10\r", data(b">$10\r", "0")),
        (b"$1B01\r", False, b">\r", Accepted(raw=b">\r", is_reply=True)),
        (b"$16\r", True, b">$100000300\r", data(b">$100000300\r", "00000300")),
        (b"$1EL1\r", False, b">\r", Accepted(raw=b">\r", is_reply=True)),
    ],
)
def test_el_table(sent: bytes, has_data: bool, reply: bytes, expected: ReplyEvent) -> None:
    assert parser_for(EL, sent, has_data).feed(reply) == [expected]


def test_el_ack_without_its_cr_is_garbled_at_quiet() -> None:
    parser = parser_for(EL, b"$10\r")
    assert parser.feed(b">") == []
    assert parser.line_quiet() == [Garbled(raw=b">", is_reply=True)]


def test_error_mark_replies() -> None:
    # manual §10 ER: '>@' without CR, '>@' CR with EL1
    parser = parser_for(ER, b"$1X\r")
    assert parser.feed(b">@") == [CommandRejected(raw=b">@", is_reply=True)]
    parser = parser_for(EL_ER, b"$1X\r")
    assert parser.feed(b">@\r") == [CommandRejected(raw=b">@\r", is_reply=True)]
    parser = parser_for(ER, b"$16X\r", True)  # a refused query
    assert parser.feed(b">@") == [CommandRejected(raw=b">@", is_reply=True)]


def test_error_mark_on_makes_a_bare_ack_wait() -> None:
    parser = parser_for(ER, b"$10\r")
    assert parser.feed(b">") == []
    assert parser.line_quiet() == [Accepted(raw=b">", is_reply=True)]
    parser.expect("1", b"$10\r", False)
    assert parser.feed(b">$1T\r") == [Accepted(raw=b">", is_reply=True), TIMER_1]
    parser.expect("1", b"$10\r", False)
    assert parser.feed(b">\r") == [Accepted(raw=b">\r", is_reply=True)]


def test_lone_at_sign_from_a_program() -> None:
    parser = parser_for(ER, b"$1\r", True)
    at = unsolicited(b"@", PROGRAM, "@", None, None)
    assert parser.feed(b"@>$10\r@") == [at, data(b">$10\r", "0"), at]


# ------------------------------------------------------------------ §7 digest: unsolicited


@pytest.mark.parametrize(
    "chunks",
    [
        (b"$1*\r>$10\r$1T\r",),  # before and after the reply
        (b"$1", b"*\r>$1", b"0\r$1", b"T", b"\r"),  # split across chunks
        (b"$1*\r>", b"$10\r$1T\r"),
    ],
)
def test_unsolicited_around_a_query_reply(chunks: tuple[bytes, ...]) -> None:
    parser = parser_for(POWER_ON, b"$1\r", True)
    assert run(parser, *chunks) == [EEPROM_1, data(b">$10\r", "0"), TIMER_1]


@pytest.mark.parametrize(
    "chunks",
    [
        (b"$1*\r$1T\r", b">"),
        (b"$", b"1*", b"\r$1T", b"\r", b">"),
    ],
)
def test_unsolicited_never_satisfies_a_pending_ack(chunks: tuple[bytes, ...]) -> None:
    parser = parser_for(POWER_ON, b"$1AW\r", False)
    events = run(parser, *chunks[:-1])
    assert events == [EEPROM_1, TIMER_1]
    assert parser.pending is not None
    assert parser.feed(chunks[-1]) == [Accepted(raw=b">", is_reply=True)]


def test_eeprom_done_after_its_ack() -> None:
    # manual §11-3: IW answers '>' at once and '$B#*' CR when the write is over
    for framing in (POWER_ON, EL):
        parser = parser_for(framing, b"$1IW\r")
        ack = encode_ack(framing, sent=b"$1IW\r")
        assert parser.feed(ack + b"$1*\r") == [Accepted(raw=ack, is_reply=True), EEPROM_1]


def test_star_and_t_are_unsolicited_even_while_a_query_waits() -> None:
    parser = parser_for(ECHO, b"$1\r", True)
    assert parser.feed(b"$1\r$1*\r$10\r") == [EEPROM_1, data(b"$1\r$10\r", "0")]


def test_unsolicited_while_nothing_is_expected() -> None:
    parser = ReplyParser()
    stream = b"$1*\r$2T\r$300000300\r>123ABC*+-%\r>$1100042\r@#4*\r"
    assert run(parser, stream) == [
        EEPROM_1,
        unsolicited(b"$2T\r", TIMER, "T", "2"),
        unsolicited(b"$300000300\r", PROGRAM, "00000300", "3"),
        unsolicited(b">123ABC*+-%\r", PROGRAM, "123ABC*+-%", None, None),  # manual §12 /CO
        unsolicited(b">$1100042\r", PROGRAM, "100042"),  # §12 /CC
        unsolicited(b"@", PROGRAM, "@", None, None),
        unsolicited(b"#4*\r", EEPROM, "*", "4", HASH),
    ]


def test_data_reply_of_another_controller_is_unsolicited() -> None:
    parser = parser_for(POWER_ON, b"$1\r", True)
    assert parser.feed(b">$2100042\r>#1100042\r") == [
        unsolicited(b">$2100042\r", PROGRAM, "100042", "2"),
        unsolicited(b">#1100042\r", PROGRAM, "100042", "1", HASH),
    ]
    assert parser.pending is not None


def test_counter_output_while_an_ack_is_pending() -> None:
    parser = parser_for(EL, b"$10\r")
    assert parser.feed(b">$1100042\r>OK\r>\r") == [
        unsolicited(b">$1100042\r", PROGRAM, "100042"),
        unsolicited(b">OK\r", PROGRAM, "OK", None, None),
        Accepted(raw=b">\r", is_reply=True),
    ]


def test_late_replies_are_not_replies() -> None:
    parser = ReplyParser()
    assert run(parser, b">", quiet=True) == [Accepted(raw=b">")]
    assert parser.feed(b">>?>@") == [
        Accepted(raw=b">"),
        Accepted(raw=b">"),
        NotAccepted(raw=b"?"),
        CommandRejected(raw=b">@"),
    ]
    assert parser.feed(b">\r") == [Accepted(raw=b">\r")]
    parser.expect("1", b"$1\r", True)
    parser.cancel()
    assert parser.pending is None
    assert parser.feed(b">$10\r") == [unsolicited(b">$10\r", PROGRAM, "0")]


# ------------------------------------------------------------------ '#' series


def test_hash_series_replies() -> None:
    parser = parser_for(POWER_ON, b"#16\r", True, series=HASH)
    assert parser.series is HASH
    assert parser.feed(b">$1T\r>#100000300\r") == [
        unsolicited(b">$1T\r", PROGRAM, "T"),  # a '$'-series controller 1
        data(b">#100000300\r", "00000300"),
    ]
    parser = parser_for(ECHO, b"#16\r", True, series=HASH)
    assert parser.feed(b"#16\r#100000300\r") == [data(b"#16\r#100000300\r", "00000300")]


# ------------------------------------------------------------------ garbage and resync


def test_garbage_ends_at_a_start_character_or_cr() -> None:
    parser = parser_for(POWER_ON, b"$1\r", True)
    assert parser.feed(b"xyz>$10\r") == [Garbled(raw=b"xyz"), data(b">$10\r", "0")]
    assert parser.feed(b"\r") == [Garbled(raw=b"\r")]
    assert parser.feed(b"ab\r") == [Garbled(raw=b"ab\r")]
    assert run(parser, b"\x00\xff", quiet=True) == [Garbled(raw=b"\x00\xff")]
    for start in b"?@$#":
        assert parser.feed(b"q" + bytes([start]))[0] == Garbled(raw=b"q")
        parser.line_quiet()


def test_dollar_restarts_a_message() -> None:
    parser = parser_for(POWER_ON, b"$1\r", True)
    assert parser.feed(b">$1$1*\r") == [Garbled(raw=b">$1", is_reply=True), EEPROM_1]
    assert parser.feed(b">AB$1*\r") == [Garbled(raw=b">AB"), EEPROM_1]
    assert parser.feed(b"$1ab#2*\r") == [
        Garbled(raw=b"$1ab"),
        unsolicited(b"#2*\r", EEPROM, "*", "2", HASH),
    ]


def test_hash_inside_program_text_does_not_restart() -> None:
    parser = ReplyParser()
    assert parser.feed(b">OK#1\r") == [unsolicited(b">OK#1\r", PROGRAM, "OK#1", None, None)]


def test_marks_without_a_body_are_garbled() -> None:
    parser = parser_for(POWER_ON, b"$1\r", True)
    assert parser.feed(b"$\r>$\r") == [Garbled(raw=b"$\r"), Garbled(raw=b">$\r")]
    assert parser.pending is not None


def test_partial_reply_claims_the_expectation_only_when_it_fits() -> None:
    parser = parser_for(POWER_ON, b"$1\r", True)
    assert run(parser, b">$2", quiet=True) == [Garbled(raw=b">$2")]
    assert run(parser, b"$1", quiet=True) == [Garbled(raw=b"$1")]
    assert run(parser, b">$1", quiet=True) == [Garbled(raw=b">$1", is_reply=True)]
    parser = parser_for(EL, b"$10\r")
    assert run(parser, b">$1", quiet=True) == [Garbled(raw=b">$1")]
    assert run(parser, b">@", quiet=True) == [Garbled(raw=b">@", is_reply=True)]
    parser = parser_for(ECHO, b"$16\r", True)
    assert run(parser, b"$2", quiet=True) == [Garbled(raw=b"$2")]
    assert run(parser, b">$1", quiet=True) == [Garbled(raw=b">$1")]


def test_overlong_messages_are_garbled() -> None:
    parser = ReplyParser()
    long = b"x" * (MAX_LINE + 5)
    assert parser.feed(long + b"\r") == [
        Garbled(raw=long[:MAX_LINE]),
        Garbled(raw=long[MAX_LINE:] + b"\r"),
    ]
    line = b">" + b"A" * MAX_LINE
    assert parser.feed(line + b"\r") == [Garbled(raw=line[:MAX_LINE]), Garbled(raw=b"A\r")]


def test_line_quiet_with_nothing_in_progress() -> None:
    parser = parser_for(POWER_ON, b"$1\r", True)
    assert parser.line_quiet() == []
    assert parser.pending == Expectation("1", b"$1\r", True, POWER_ON, DOLLAR)


def test_expect_checks_its_arguments() -> None:
    parser = ReplyParser(ECHO)
    with pytest.raises(ValueError, match="body number"):
        parser.expect("F", b"$F\r", True)
    with pytest.raises(ValueError, match="echo"):
        parser.expect("1", b"", False)
    parser.expect("1", b"", False, framing=replace(ECHO, echo=False))  # program text: no echo
    assert parser.feed(b">") == [Accepted(raw=b">", is_reply=True)]


def test_configure_keeps_what_is_not_given() -> None:
    parser = ReplyParser()
    parser.configure(series=HASH)
    assert (parser.framing, parser.series) == (POWER_ON, HASH)
    parser.configure(framing=EL)
    assert (parser.framing, parser.series) == (EL, HASH)


def test_every_event_type() -> None:
    parser = parser_for(SUM, b"$155\r", True)
    events = run(parser, b"xx$1*\r>$10C5\r")
    parser.expect("1", b"$155\r", True)
    events += run(parser, b">$10C3\r>@@>$1T00\r")
    parser.expect("1", b"$155\r", True)
    events += run(parser, b"?")
    parser.expect("1", b"$10" + checksum(b"$10") + b"\r", False)
    events += run(parser, b">")
    assert [type(e) for e in events] == [
        Garbled,
        Unsolicited,
        ChecksumMismatch,
        DataReply,
        CommandRejected,
        Unsolicited,
        ChecksumMismatch,
        NotAccepted,
        Accepted,
    ]
    parser.configure(framing=POWER_ON)
    events += run(parser, b"$1T\r>OK\r")
    assert {e.kind for e in events if isinstance(e, Unsolicited)} == set(UnsolicitedKind)


# ------------------------------------------------------------------ every framing combination

QUERY_DATA = "00000300"
CASES = ["ack", "error", "data", "refused_query", "refused_query_error", "not_accepted"]
UNSOLICITED = ["eeprom", "timer", "program_query", "co", "cc", "at"]


def reply_case(
    framing: Framing, case: str, series: Series = DOLLAR, body: str = "1", text: str = "OH100"
) -> tuple[bytes, bool, bytes, ReplyEvent]:
    """(sent, has_data, device bytes, the event the parser must give) for one reply."""
    sent = encode_command(body, text, series=series, framing=framing)
    error = case.endswith("error")
    if case == "data":
        reply = encode_data(body, QUERY_DATA, framing, series=series, sent=sent)
        return sent, True, reply, DataReply(raw=reply, is_reply=True, body=body, data=QUERY_DATA)
    if case == "not_accepted":
        return sent, True, encode_not_accepted(), NotAccepted(raw=b"?", is_reply=True)
    reply = encode_ack(framing, sent=sent, error=error)
    kind = CommandRejected if error and framing.error_mark else Accepted
    return sent, case.startswith("refused"), reply, kind(raw=reply, is_reply=True)


def unsolicited_case(
    framing: Framing, case: str, series: Series = DOLLAR, body: str = "2", value: str = "OK1"
) -> tuple[bytes, Unsolicited]:
    if case == "eeprom":
        wire = encode_unsolicited(body, EEPROM_DONE, framing, series=series)
        return wire, unsolicited(wire, EEPROM, "*", body, series)
    if case == "timer":
        wire = encode_unsolicited(body, TIMER_UP, framing, series=series)
        return wire, unsolicited(wire, TIMER, "T", body, series)
    if case == "program_query":
        wire = encode_unsolicited(body, value, framing, series=series)
        return wire, unsolicited(wire, PROGRAM, value, body, series)
    if case == "co":
        wire = encode_program_message(value, framing)
        return wire, unsolicited(wire, PROGRAM, value, None, None)
    if case == "cc":
        wire = encode_program_message(f"{series.value}{body}1{value}", framing)
        return wire, unsolicited(wire, PROGRAM, f"1{value}", body, series)
    wire = encode_program_error()
    return wire, unsolicited(wire, PROGRAM, "@", None, None)


@pytest.mark.parametrize("framing", ALL_FRAMINGS, ids=repr)
@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("series", list(Series))
def test_every_framing_round_trips(framing: Framing, case: str, series: Series) -> None:
    sent, has_data, reply, expected = reply_case(framing, case, series)
    parser = ReplyParser(framing, series)
    parser.expect("1", sent, has_data)
    assert run(parser, reply, quiet=True) == [expected]
    assert parser.pending is None


@pytest.mark.parametrize("framing", ALL_FRAMINGS, ids=repr)
@pytest.mark.parametrize("case", UNSOLICITED)
def test_every_framing_unsolicited(framing: Framing, case: str) -> None:
    wire, expected = unsolicited_case(framing, case)
    assert run(ReplyParser(framing), wire, quiet=True) == [expected]
    parser = ReplyParser(framing)
    parser.expect("1", encode_command("1", "", framing=framing), True)
    if case == "co" and not framing.cr_after_ack and not framing.echo:
        # With EL0 and no program known to run, '>' then text is the pending query's bare '>'
        # and a damaged rest; while a program may print, it is a /CO line (docs/manual-notes.md
        # "/CO output: with or without '>'").
        assert run(parser, wire) == [Accepted(raw=b">", is_reply=True), Garbled(raw=wire[1:])]
        parser = ReplyParser(framing)
        parser.configure(printing=True)
        parser.expect("1", encode_command("1", "", framing=framing), True)
    assert run(parser, wire) == [expected]
    assert parser.pending is not None


@pytest.mark.parametrize("framing", [f for f in ALL_FRAMINGS if not f.echo], ids=repr)
def test_a_co_line_before_a_general_reply_is_output_when_a_program_may_print(
    framing: Framing,
) -> None:
    # A program's output ready before the frame was heard comes before its reply
    # (docs/manual-notes.md "A program's output and a reply in progress").
    wire, expected = unsolicited_case(framing, "co")
    sent = encode_command("1", "GS", framing=framing)
    reply = encode_ack(framing, sent=sent)
    parser = ReplyParser(framing)
    parser.configure(printing=True)
    parser.expect("1", sent, False)
    assert run(parser, wire + reply, quiet=True) == [expected, Accepted(raw=reply, is_reply=True)]
    # and after the reply: '>' then the line
    parser.expect("1", sent, False)
    assert run(parser, reply + wire, quiet=True) == [Accepted(raw=reply, is_reply=True), expected]


def test_a_general_reply_does_not_wait_when_no_program_may_print() -> None:
    parser = ReplyParser(Framing())
    parser.expect("1", b"$1GS\r", False)
    assert parser.feed(b">") == [Accepted(raw=b">", is_reply=True)]


@pytest.mark.parametrize("framing", [f for f in ALL_FRAMINGS if f.checksum], ids=repr)
def test_every_checksum_framing_detects_a_changed_digit(framing: Framing) -> None:
    sent, has_data, reply, _ = reply_case(framing, "data")
    damaged = reply[:-2] + (b"0" if reply[-2:-1] != b"0" else b"1") + b"\r"
    parser = ReplyParser(framing)
    parser.expect("1", sent, has_data)
    assert parser.feed(damaged) == [ChecksumMismatch(raw=damaged, is_reply=True)]


# ------------------------------------------------------------------ properties

FRAMINGS = st.sampled_from(ALL_FRAMINGS)
SERIES = st.sampled_from(list(Series))
DATA_TEXT = st.text(
    st.sampled_from([chr(c) for c in range(0x20, 0x7F) if chr(c) not in "$#"] + ["\uff71"]),
    max_size=12,
)
COMMAND_TEXT = DATA_TEXT.filter(lambda t: t not in ("*", "T"))


@given(
    FRAMINGS,
    SERIES,
    st.lists(
        st.one_of(
            st.binary(max_size=16),
            st.sampled_from([b">", b"?", b"@", b"$", b"#", b"\r", b">$1", b"$1", b"$1*\r"]),
            st.sampled_from(["quiet", "expect", "expect_data", "cancel"]),
        ),
        max_size=40,
    ),
)
def test_parser_never_raises(framing: Framing, series: Series, actions: list[bytes | str]) -> None:
    parser = ReplyParser(framing, series)
    sent = encode_command("1", "6", series=series, framing=framing)
    fed = consumed = 0
    for action in actions:
        if action == "quiet":
            events = parser.line_quiet()
        elif action == "cancel":
            parser.cancel()
            continue
        elif isinstance(action, str):
            parser.expect("1", sent, action == "expect_data")
            continue
        else:
            fed += len(action)
            events = parser.feed(action)
        consumed += sum(len(e.raw) for e in events)
    consumed += sum(len(e.raw) for e in parser.line_quiet())
    # every byte read ends up in exactly one event; only expect() and cancel() drop a matched
    # echo whose response part had not come
    if all(isinstance(a, bytes) or a == "quiet" for a in actions):
        assert consumed == fed
    assert consumed <= fed


@given(
    st.binary(max_size=40),
    st.sampled_from(["quiet", "cr"]),
    FRAMINGS,
    SERIES,
    st.sampled_from(CASES),
    COMMAND_TEXT,
)
def test_resync_after_garbage(
    garbage: bytes, how: str, framing: Framing, series: Series, case: str, text: str
) -> None:
    parser = ReplyParser(framing, series)
    parser.feed(garbage)
    if how == "quiet":
        parser.line_quiet()
    else:
        parser.feed(b"\r")
    sent, has_data, reply, expected = reply_case(framing, case, series, text=text)
    parser.expect("1", sent, has_data)
    assert run(parser, reply, quiet=True) == [expected]


@st.composite
def valid_streams(
    draw: st.DrawFn,
) -> tuple[Framing, Series, bytes, bool, list[bytes], list[ReplyEvent]]:
    framing, series = draw(FRAMINGS), draw(SERIES)
    sent, has_data, reply, expected = reply_case(
        framing, draw(st.sampled_from(CASES)), series, text=draw(COMMAND_TEXT)
    )
    before = draw(st.lists(st.sampled_from(["eeprom", "timer", "program_query", "at"]), max_size=3))
    after = draw(st.lists(st.sampled_from(UNSOLICITED), max_size=3))
    value = draw(
        DATA_TEXT.filter(lambda t: t not in ("*", "T") and t[:1] not in ("", ">", "?", "@"))
    )
    pieces: list[bytes] = []
    events: list[ReplyEvent] = []
    for case in before:
        wire, event = unsolicited_case(framing, case, series, value=value)
        pieces.append(wire)
        events.append(event)
    pieces.append(reply)
    events.append(expected)
    segment_2 = []
    for case in after:
        wire, event = unsolicited_case(framing, case, series, value=value)
        segment_2.append(wire)
        events.append(event)
    return framing, series, sent, has_data, [b"".join(pieces), b"".join(segment_2)], events


@given(
    valid_streams(),
    st.lists(st.integers(0, 60), max_size=8),
    st.lists(st.integers(0, 60), max_size=8),
)
def test_chunking_does_not_change_the_events(
    stream: tuple[Framing, Series, bytes, bool, list[bytes], list[ReplyEvent]],
    cuts_1: list[int],
    cuts_2: list[int],
) -> None:
    framing, series, sent, has_data, segments, expected = stream

    def parse(cuts: tuple[list[int], list[int]]) -> list[ReplyEvent]:
        parser = ReplyParser(framing, series)
        parser.expect("1", sent, has_data)
        events: list[ReplyEvent] = []
        for segment, segment_cuts in zip(segments, cuts, strict=True):
            for piece in _split(segment, segment_cuts):
                events += parser.feed(piece)
            events += parser.line_quiet()  # a reply with EL0 may wait for the next byte
        return events

    assert parse(([], [])) == expected
    assert parse((cuts_1, cuts_2)) == expected
    whole = b"".join(segments)
    one = ReplyParser(framing, series)
    one.expect("1", sent, has_data)
    many = ReplyParser(framing, series)
    many.expect("1", sent, has_data)
    split_events: list[ReplyEvent] = []
    for piece in _split(whole, cuts_1 + cuts_2):
        split_events += many.feed(piece)
    assert one.feed(whole) + one.line_quiet() == split_events + many.line_quiet()


def _split(data: bytes, cuts: list[int]) -> list[bytes]:
    pieces, pos = [], 0
    for cut in cuts:
        pieces.append(data[pos : pos + cut])
        pos += cut
    pieces.append(data[pos:])
    return pieces
