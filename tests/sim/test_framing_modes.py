"""The framing switches EE, EL, ER and SUM, byte for byte, as the manual's tables print them.

§10 EE (echo back), §10 EL (CR after '>'), §10 ER (">@" for a command error, ROM 1.19+) and
§10 SUM (checksums on commands and replies). Each manual table is a parametrised test with the
manual's own bytes; the combinations the manual does not print follow the decisions of
docs/manual-notes.md ("Framing and the reply stream"), named where they are used.

The checksum is written here from the manual's rule, not taken from the gateway: the low byte of
the sum of the ASCII codes of everything before it, as two upper-case hex digits (§10 SUM).
"""

from __future__ import annotations

import itertools

import pytest

from tests.sim.direct import Direct

ACK = b">"


def sum8(body: bytes) -> bytes:
    """§10 SUM: the sum of the ASCII codes in hex, its last two digits ("10F" -> "0F")."""
    return b"%02X" % (sum(body) % 256)


def framed(text: str, *, checksum: bool, body: str = "1") -> bytes:
    """A command frame: '$' B# text [checksum] CR (§9-1, §10 SUM 送信フォーマット)."""
    payload = f"${body}{text}".encode("latin-1")
    return payload + (sum8(payload) if checksum else b"") + b"\r"


# ============================================================== the checksum rule itself


@pytest.mark.parametrize(
    ("plain", "with_sum"),
    [
        (b"$1\r", b"$155\r"),  # §10 SUM <コマンド送信例>: 36 + 49 = 85 = 55h
        (b"$16\r", b"$168B\r"),  # 139 = 8Bh
        (b"$1A01300\r", b"$1A013008A\r"),  # 394 = 18Ah -> "8A"
    ],
)
def test_the_checksum_helper_reproduces_the_manual_send_examples(
    plain: bytes, with_sum: bytes
) -> None:
    assert plain[:-1] + sum8(plain[:-1]) + b"\r" == with_sum


@pytest.mark.parametrize(
    ("reply", "ok"),
    [(b">$10C3\r", True), (b">$10C5\r", False), (b">$108FB\r", True)],  # §10 SUM 応答受信例
)
def test_the_checksum_helper_reproduces_the_manual_reply_examples(reply: bytes, ok: bool) -> None:
    assert (sum8(reply[:-3]) == reply[-3:-1]) is ok


# ============================================================== EE: echo back (§10 EE)


def echo_on() -> Direct:
    direct = Direct()
    direct.cmd("R300")  # position 300, the position of the manual's $16 example
    assert direct.cmd("EE1") == ACK  # §10 EE (I): answered '>'
    return direct


# §10 EE 解説 table (echo ON column). "$1B01" is printed although B needs a 3-digit position
# number; the echo is the same either way (docs/manual-notes.md "$1B01 in the EE and EL tables").
EE_TABLE = [
    (b"$1\r", b"$1\r$10\r"),
    (b"$10\r", b"$10\r"),
    (b"$16\r", b"$16\r$100000300\r"),
    (b"$1B01\r", b"$1B01\r"),
    (b"$1B001\r", b"$1B001\r"),
]


@pytest.mark.parametrize(("sent", "reply"), EE_TABLE)
def test_echo_table(sent: bytes, reply: bytes) -> None:
    assert echo_on().send(sent) == reply


@pytest.mark.parametrize(("sent", "echo_off"), [
    (b"$1\r", b">$10\r"), (b"$10\r", b">"), (b"$16\r", b">$100000300\r"), (b"$1B001\r", b">"),
])  # fmt: skip
def test_echo_table_off_column(sent: bytes, echo_off: bytes) -> None:
    direct = Direct()
    direct.cmd("R300")
    assert direct.send(sent) == echo_off


def test_echo_queries_and_switching_off() -> None:
    direct = echo_on()
    assert direct.cmd("EE") == b"$1EE\r$11\r"  # §10 EE (III): 9 characters when on (§15)
    assert direct.cmd("EE0") == b"$1EE0\r"  # §10 EE (II): answered with its echo
    assert direct.cmd("EE") == b">$10\r"  # 5 characters when off
    assert direct.cmd("EE0") == ACK  # "既に機能が解除されているときは書式 (I) の場合と同じ応答"
    assert direct.cmd("") == b">$10\r"


def test_echo_repeats_the_frame_exactly_as_received() -> None:
    # §10 EE: エコーバック部 = RC-233 が受信したコマンド本体, including a command in error.
    direct = echo_on()
    assert direct.cmd("OH05000") == b"$1OH05000\r"
    assert direct.cmd("XYZ") == b"$1XYZ\r"
    assert direct.cmd("9") == b"$19\r$108\r"


# ============================================================== EL: CR after '>' (§10 EL)


def el_on() -> Direct:
    direct = Direct()
    direct.cmd("R300")
    assert direct.cmd("EL1") == b">\r"  # §10 EL (I): the reply to EL1 is already '>' CR
    return direct


# §10 EL 解説 table. The OCR prints the $16 reply without '$'; query replies are "unchanged"
# (§10 EL (I)), so it is the normal query reply.
EL_TABLE = [
    (b"$10\r", b">\r", b">"),
    (b"$1\r", b">$10\r", b">$10\r"),
    (b"$1B01\r", b">\r", b">"),
    (b"$16\r", b">$100000300\r", b">$100000300\r"),
]


@pytest.mark.parametrize(("sent", "on", "off"), EL_TABLE)
def test_cr_table(sent: bytes, on: bytes, off: bytes) -> None:
    assert el_on().send(sent) == on
    direct = Direct()
    direct.cmd("R300")
    assert direct.send(sent) == off


def test_cr_query_and_switching_off() -> None:
    direct = el_on()
    assert direct.cmd("EL") == b">$11\r"
    assert direct.cmd("EL0") == ACK  # §10 EL (II): back to '>' alone
    assert direct.cmd("EL") == b">$10\r"
    assert direct.cmd("D00") == ACK


# ============================================================== ER: ">@" (§10 ER)


def test_error_mark_on_a_command_error_only() -> None:
    direct = Direct()
    assert direct.cmd("ER1") == ACK  # §10 ER (I): '>'
    assert direct.cmd("XYZ") == b">@"  # no CR after '@' (§10 ER 注意点)
    assert direct.cmd("OH6000") == ACK
    assert direct.cmd("ER") == b">$11\r"
    assert direct.cmd("ER0") == ACK
    assert direct.cmd("XYZ") == ACK
    assert direct.cmd("ER") == b">$10\r"


def test_error_mark_leaves_the_flags_as_they_are() -> None:
    # §10 ER 注意点: この機能自体は、コマンド "" 及び "9" のコマンド・エラーのフラグを
    # 書き替えません.
    direct = Direct()
    direct.cmd("ER1")
    direct.cmd("XYZ")
    assert direct.cmd("") == b">$18\r"
    assert direct.cmd("9") == b">$108\r"


@pytest.mark.parametrize(
    ("setup", "text"),
    [
        ([], "OH16384"),  # out of range (§10 OH)
        (["OC100"], "OH9000"),  # S-curve inequality (§10 OH 重要な注意事項)
        ([], "QJ"),  # a mode-1 query in mode 0 (§10 QJ): no data, just '>@'
        ([], "RD"),  # mode 1 only (§10 RD)
        ([], "KC"),  # the error-output function is off (§10 K (IV))
    ],
)
def test_every_kind_of_command_error_gets_the_mark(setup: list[str], text: str) -> None:
    direct = Direct()
    for s in setup:
        direct.cmd(s)
    direct.cmd("ER1")
    assert direct.cmd(text) == b">@"


def test_error_mark_with_el_ends_with_cr() -> None:
    # §10 ER 注意点: [CR] を追加したいときは、コマンド "EL" を設定してください.
    direct = Direct()
    direct.cmd("ER1")
    direct.cmd("EL1")
    assert direct.cmd("XYZ") == b">@\r"
    assert direct.cmd("D00") == b">\r"


def test_error_mark_for_a_motion_command_while_moving() -> None:
    # §9-1 注意: a motion command while the motor turns is a command error.
    direct = Direct()
    direct.cmd("ER1")
    assert direct.cmd("7") == ACK
    direct.advance(1.0)
    assert direct.cmd("7") == b">@"


# ============================================================== SUM: checksums (§10 SUM)


def sum_on(*, el: bool = False) -> Direct:
    direct = Direct()
    direct.cmd("R0")
    if el:
        assert direct.cmd("EL1") == b">\r"
    # §13-2 ② example 1 sends EL1, then SUM1. The reply to SUM1 is framed as before it
    # (docs/manual-notes.md "Whether the reply to SUM1 (and SUM0) carries a checksum").
    assert direct.cmd("SUM1") == (b">\r" if el else ACK)
    return direct


def test_manual_sum_examples() -> None:
    direct = sum_on()
    assert direct.send(b"$155\r") == b">$10C3\r"  # §10 SUM: "$1" -> ">$10" + C3
    position = b">$100000000"
    assert direct.send(b"$168B\r") == position + sum8(position) + b"\r"
    assert direct.send(b"$1A013008A\r") == ACK  # A013 := 0 (§10 SUM third example)


def test_manual_reply_example_108FB_is_the_command_error_condition() -> None:
    direct = sum_on()
    assert direct.send(framed("XYZ", checksum=True)) == ACK
    assert direct.send(framed("9", checksum=True)) == b">$108FB\r"  # §10 SUM 応答受信例


def test_sum_query_with_sum_on_matches_the_manual() -> None:
    # §10 SUM (III): "[B#] が 1 のとき、ASCII は [C 4]": >$11 + C4 + CR (7 characters, §15).
    direct = sum_on()
    assert direct.send(framed("SUM", checksum=True)) == b">$11C4\r"


def test_sum_query_with_sum_off() -> None:
    assert Direct().cmd("SUM") == b">$10\r"  # 5 characters (§15)


@pytest.mark.parametrize(
    "frame",
    [
        b"$156\r",  # the manual's "$1" with a wrong checksum
        b"$168b\r",  # lower-case hex digits (docs/manual-notes.md "Case of the checksum digits")
        b"$1\r",  # no checksum at all
        b"$1OH1000" + b"00\r",
    ],
)
def test_a_bad_checksum_is_answered_question_mark_and_not_executed(frame: bytes) -> None:
    # §10 SUM 受信フォーマット, CR が付かない場合: one character = "checksum NG"; §9-2: '?'.
    direct = sum_on()
    assert direct.send(frame) == b"?"
    assert direct.send(framed("OH", checksum=True)) == b">$105000" + sum8(b">$105000") + b"\r"
    # '?' is not a command error (§9-2: 「コマンドにエラーが有ったことを意味するものではない」).
    assert direct.send(framed("", checksum=True)) == b">$10C3\r"


def test_a_bad_checksum_is_answered_question_mark_also_with_el_and_er() -> None:
    # '?' never carries a CR or a checksum (docs/manual-notes.md "The one-character replies").
    direct = sum_on(el=True)
    direct.send(framed("ER1", checksum=True))
    assert direct.send(b"$156\r") == b"?"


def test_sum_with_el_puts_a_checksum_on_the_ack() -> None:
    # §10 SUM: コマンド "EL1" を予め送っておくと、正常時応答が [>] のみでも、「[CR] が付く場合の
    # 応答」の受信フォーマット: '>' + sum('>') + CR = ">3E" CR.
    direct = sum_on(el=True)
    assert direct.send(framed("D00", checksum=True)) == b">3E\r"
    assert direct.send(framed("", checksum=True)) == b">$10C3\r"


def test_sum_with_er_and_el() -> None:
    # ">@" with EL1 is a CR reply, so it carries the checksum of ">@" (62 + 64 = 7Eh).
    direct = sum_on(el=True)
    assert direct.send(framed("ER1", checksum=True)) == b">3E\r"
    assert direct.send(framed("XYZ", checksum=True)) == b">@7E\r"


def test_sum_with_er_without_el() -> None:
    direct = sum_on()
    direct.send(framed("ER1", checksum=True))
    assert direct.send(framed("XYZ", checksum=True)) == b">@"


def test_sum0_returns_to_plain_frames() -> None:
    # §10 SUM 解説: 書式 (II) で解除すると、コマンドの送信書式及び、応答の書式は通常の形式に戻る.
    direct = sum_on()
    assert direct.send(framed("SUM0", checksum=True)) == ACK
    assert direct.cmd("") == b">$10\r"
    assert direct.cmd("SUM") == b">$10\r"


def test_eeprom_done_message_carries_a_checksum() -> None:
    # §10 SUM: the format applies to replies that end with CR; docs/manual-notes.md
    # "Checksums of unsolicited messages": $1* + sum("$1*") = 36 + 49 + 42 = 127 = 7Fh.
    direct = sum_on()
    assert direct.send(framed("DW", checksum=True)) == ACK
    direct.advance(30.0)
    assert direct.due() == [b"$1*7F\r"]


# ============================================================== EE and SUM exclude each other


def test_ee1_with_sum_on_is_refused() -> None:
    # §10 EE 注意点: "SUM" と "EE" を同時に設定することは出来ません (docs/manual-notes.md
    # "EE together with SUM": a command error, nothing changes).
    direct = sum_on()
    assert direct.send(framed("EE1", checksum=True)) == ACK
    reply = b">$10"
    assert direct.send(framed("EE", checksum=True)) == reply + sum8(reply) + b"\r"
    reply = b">$18"
    assert direct.send(framed("", checksum=True)) == reply + sum8(reply) + b"\r"


def test_sum1_with_echo_on_is_refused() -> None:
    # §10 SUM 注意点: コマンド "EE" を解除してから使用してください.
    direct = echo_on()
    assert direct.cmd("SUM1") == b"$1SUM1\r"  # a general reply with echo: the echo only
    assert direct.cmd("SUM") == b"$1SUM\r$10\r"
    assert direct.cmd("") == b"$1\r$18\r"


def test_ee1_after_sum0_is_accepted() -> None:
    direct = sum_on()
    direct.send(framed("SUM0", checksum=True))
    assert direct.cmd("EE1") == ACK
    assert direct.cmd("") == b"$1\r$10\r"


# ============================================================== combinations


def expected(
    kind: str, *, ee: bool, el: bool, er: bool, sm: bool, sent: bytes, data: bytes = b""
) -> bytes:
    """The reply the manual's rules give, for a general reply, an error, or a query.

    EE: echo + the normal reply minus '>' (nothing more when that is just '>'); with EL1 the
    echo of a general reply is followed by CR (docs/manual-notes.md "EE1 with EL1"), with ER1
    by '@' ("EE1 with ER1"). EL: '>' becomes '>' CR. ER: '>' becomes '>@'. SUM: every reply
    ending with CR gets the checksum of what precedes it.
    """
    if kind == "query":
        line = b"$1" + data
        if ee:
            return sent + line + b"\r"
        line = b">" + line
        return line + (sum8(line) if sm else b"") + b"\r"
    mark = b"@" if kind == "error" and er else b""
    if ee:
        return sent + mark + (b"\r" if el else b"")
    if not el:
        return b">" + mark
    line = b">" + mark
    return line + (sum8(line) if sm else b"") + b"\r"


COMBINATIONS = [
    (ee, el, er, sm)
    for ee, el, er, sm in itertools.product((False, True), repeat=4)
    if not (ee and sm)  # §10 EE 注意点, §10 SUM 注意点
]


def _ids(combo: tuple[bool, bool, bool, bool]) -> str:
    names = ("EE", "EL", "ER", "SUM")
    return "+".join(n for n, on in zip(names, combo, strict=True) if on) or "plain"


def _configured(ee: bool, el: bool, er: bool, sm: bool) -> Direct:
    direct = Direct()
    direct.cmd("R300")
    direct.cmd("EL1" if el else "EL0")
    direct.cmd("ER1" if er else "ER0")
    if ee:
        direct.cmd("EE1")
    if sm:
        direct.cmd("SUM1")
    return direct


@pytest.mark.parametrize("combo", COMBINATIONS, ids=_ids)
def test_every_combination_of_the_switches(combo: tuple[bool, bool, bool, bool]) -> None:
    ee, el, er, sm = combo
    direct = _configured(ee, el, er, sm)
    flags = dict(ee=ee, el=el, er=er, sm=sm)
    for kind, text, data in [
        ("general", "D00", b""),
        ("error", "XYZ", b""),
        ("query", "6", b"00000300"),
        ("query", "9", b"08"),  # the command error of XYZ, in the condition store
        ("query", "", b"8"),  # and in the status store
        ("query", "", b"0"),
        ("query", "OH", b"05000"),
    ]:
        sent = framed(text, checksum=sm)
        assert direct.send(sent) == expected(kind, sent=sent, data=data, **flags), text
