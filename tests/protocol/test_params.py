"""Each parameter kind refuses text that breaks its rule, naming the parameter and the rule."""

from __future__ import annotations

import pytest

from gateway.errors import ParameterError
from gateway.protocol.params import (
    CharChoice,
    Dec,
    Digits,
    HexDigit,
    IntChoice,
    Param,
    Position,
    PositionFormat,
)
from gateway.protocol.text_params import Jump, Label, Text, jump_count


@pytest.mark.parametrize(
    ("param", "text", "why"),
    [
        (Dec("hs", lo=1, hi=16383, digits=5), "12a", "decimal digits"),
        (Dec("hs", lo=1, hi=16383, digits=5), "１２", "decimal digits"),  # full-width (§9-1)
        (Dec("hs", lo=1, hi=16383, digits=5), "123456", "at most 5 digits"),
        (Dec("hs", lo=1, hi=16383, digits=5), "0", "out of range 1-16383"),
        (Digits("pn", lo=0, hi=999, digits=3), "01", "exactly 3"),
        (HexDigit("du"), "g", "upper-case hex"),
        (HexDigit("du"), "f", "upper-case hex"),
        (HexDigit("dt", lo=1, hi=7), "8", "out of range 1-7"),
        (IntChoice("mt", values=(1, 2)), "3", "one of 1, 2"),
        (CharChoice("dir", values=("+", "-")), "*", "one of + -"),
        (Position("pp"), "1x", "decimal digits"),
        (Position("pp"), "123456789", "at most 8 digits"),
        (Position("pp"), "-12345678", "at most 7 digits"),
        (Position("pp"), "-9999999", "24-bit"),
        (Position("pp"), "+9000000", "signed positions end at +8388607"),
        (Text("dt", max_len=20), "", "1-20 characters"),
        (Text("dt", max_len=20), "X" * 21, "1-20 characters"),
        (Text("dt", max_len=20), "a$b", "'$'"),
        (Label("lb", host=True), "a", "label character"),
        (Label("lb"), "A", "label character"),
        (Label("lb"), "#", "label character"),
        (Jump("jump"), "B1", "jump operand"),
        (Jump("jump"), "+1000", "jump operand"),
        (Jump("jump"), "A0", "count from 1"),
        (Jump("jump"), "G10", "count from 1"),
    ],
)
def test_bad_text_names_the_parameter_and_the_rule(param: Param, text: str, why: str) -> None:
    with pytest.raises(ParameterError) as caught:
        param.decode(text)
    assert why in str(caught.value)
    assert caught.value.field == param.name
    assert caught.value.rule == param.rule()


@pytest.mark.parametrize(
    ("param", "text", "value"),
    [
        (Dec("hs", lo=1, hi=16383, digits=5), "05000", 5000),
        (Digits("pn", lo=0, hi=999, digits=3), "007", 7),
        (HexDigit("du"), "F", 15),
        (IntChoice("mt", values=(1, 2)), "2", 2),
        (Position("pp"), "16777215", 16_777_215),
        (Position("pp"), "-8388608", -8_388_608),
        (Position("pp"), "+0000001", 1),
        (Text("dt", max_len=20), "123ABC*+-%", "123ABC*+-%"),  # §12 /CO example
        (Label("lb"), "\uff71", "\uff71"),  # half-width katakana ｱ
        (Label("lb"), "z", "z"),
        (Jump("jump"), "Gｱ1", "Gｱ1"),
    ],
)
def test_good_text_decodes(param: Param, text: str, value: object) -> None:
    assert param.decode(text) == value


def test_encoding_is_canonical() -> None:
    assert Digits("pn", lo=0, hi=999, digits=3).encode(1) == "001"
    assert HexDigit("du").encode(10) == "A"
    assert Dec("hs", lo=1, hi=16383, digits=5).encode(5000) == "5000"


def test_jump_counts() -> None:
    assert [jump_count(j) for j in ("+1", "-7", "A12", "G11", "Ga999", "G123")] == [
        1,
        7,
        12,
        1,
        999,
        23,  # label '1', count 23
    ]


def test_position_formats_have_their_bounds() -> None:
    assert PositionFormat.UNSIGNED.bounds == (0, 16_777_215)
    assert PositionFormat.SIGNED.bounds == (-8_388_608, 8_388_607)


def test_rules_read_as_the_manual_states_them() -> None:
    assert Dec("bit", lo=0, hi=7, digits=1).rule() == "bit: decimal 0-7, 1 digit"
    assert "exactly 3 decimal digits" in Digits("pn", lo=0, hi=999, digits=3).rule()
    assert "lower-case a-z only as jump targets" in Label("lb", host=True).rule()
