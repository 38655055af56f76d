"""The registry: every form parses back from its own text, nothing is ambiguous, and bad
text is refused with the rule it breaks."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import TypeAdapter, ValidationError

from gateway.errors import CommandFormError, ParameterError, UnknownCommandError
from gateway.protocol.catalog import ALL_COMMANDS
from gateway.protocol.command_text import (
    REGISTRY,
    Context,
    Entry,
    Registry,
    command_union,
    parse,
    parse_statement,
)
from gateway.protocol.params import PositionFormat
from gateway.protocol.spec import Effect, ReplyFormat
from tests.support.manual_chapters import CHAPTER_10, CHAPTER_12
from tests.support.strategies import form_values

ENTRIES = REGISTRY.entries


def contexts(entry: Entry) -> list[Context]:
    return [c for c in Context if entry.usable_in(c)]


def test_every_mnemonic_of_chapters_10_and_12_is_in_the_catalog() -> None:
    names = ['""' if s.mnemonic == "" else s.mnemonic for s in REGISTRY.commands]
    assert sorted(names) == sorted(CHAPTER_10 + CHAPTER_12)


def test_keys_and_model_names_are_unique() -> None:
    keys = [e.key for e in ENTRIES]
    names = [e.model.__name__ for e in ENTRIES]
    assert len(set(keys)) == len(keys)
    assert len(set(names)) == len(names)


def test_a_mnemonic_defined_twice_is_refused() -> None:
    with pytest.raises(ValueError, match="defined twice"):
        Registry(ALL_COMMANDS + ALL_COMMANDS[:1])


@pytest.mark.parametrize("entry", ENTRIES, ids=lambda e: e.key)
@settings(max_examples=25, deadline=None)
@given(data=st.data())
def test_every_form_round_trips_and_fits_exactly_one_form(
    entry: Entry, data: st.DataObject
) -> None:
    values: dict[str, Any] = data.draw(form_values(entry))
    command = entry.model(**values)
    text = command.wire()
    for context in contexts(entry):
        matches = [e.key for e in REGISTRY.matches(text, context)]
        assert matches == [entry.key], f"{text!r} in {context}: {matches}"
        again = REGISTRY.parse(text, context=context)
        assert again == command
        assert again.wire() == text


@pytest.mark.parametrize(
    ("text", "key"),
    [
        # zero and letter O are different commands (§2, appendix)
        ("0S20", "0S{pd}"),
        ("OS300", "OS{ss}"),
        ("0S", "0S"),
        ("OS", "OS"),
        ("0X1", "0X1"),
        ("OX300", "OX{xs}"),
        ("0H", "0H"),
        ("0H2", "0H{mt}"),
        ("OH5000", "OH{hs}"),
        ("QS12", "QS{m2}{m1}"),
        ("QSE01", "QSE{m2}{m1}"),
        ("QSR", "QSR"),
        ("QSER", "QSER"),
        ("B001", "B{pn}"),
        ("B0012", "B{pn}{mt}"),
        ("B2", "B{mt}"),
        ("BN", "BN"),
        ("B+", "B{dir}"),
        ("B001-", "B{pn}{dir}"),
        ("B0011+", "B{pn}{mt}{dir}"),
        ("EE", "EE"),
        ("EE1", "EE1"),
        ("EE///", "EE///"),
        ("G", "G"),
        ("G1", "G{lb}"),
        ("GA", "GA"),
        ("GAS", "GAS"),
        ("GSS", "GSS"),
        ("GS", "GS"),
        ("", '""'),
        ("9", "9"),
        ("94", "9{bit}"),
        ("K1,3F", "K{dt},{du}{dl}"),
        ("K1,3", "K{dt},{bt}"),
        ("T*100", "T*{time}"),
        ("N32000,5000", "N{pn}{sp},{pj}"),
        ("N3", "N{pn}"),
        ("D01B", "D{bit}{value}B"),
        ("D0F", "D{du}{dl}"),
        ("DA30F", "DA{dc}{du}{dl}"),
        ("A01300", "A{pn}{pp}"),
        ("A013D", "A{pn}D"),
        ("2D", "2D"),
        ("6", "6"),
        ("62", "6{mt}"),
    ],
)
def test_look_alike_texts_land_on_their_own_form(text: str, key: str) -> None:
    assert parse(text).key == key


def test_manual_examples_parse_to_their_values() -> None:
    assert parse("OH4000").params() == {"hs": 4000}
    assert parse("A01300").params() == {"pn": 13, "pp": 0}  # §10 SUM example '$1A01300'
    assert parse("B0012").params() == {"pn": 1, "mt": 2}
    assert parse("N32000,5000").params() == {"pn": 3, "sp": 2000, "pj": 5000}  # §10 N example
    assert parse("EA51B").params() == {"bit": 5, "value": 1}  # §13-2 mode-2 set-up
    assert parse("0Z3").params() == {"n": 3}


@pytest.mark.parametrize(
    ("text", "error", "field", "words"),
    [
        ("XYZ", UnknownCommandError, "text", "unknown command mnemonic"),
        ("OH123456", ParameterError, "hs", "at most 5 digits"),
        ("OH20000", ParameterError, "hs", "out of range 1-16383"),
        ("OH0", ParameterError, "hs", "out of range 1-16383"),
        ("OC101", ParameterError, "dt", "out of range 0-100"),
        ("B12", ParameterError, "pn", "exactly 3 decimal digits"),
        ("B1234", ParameterError, "mt", "one of 1, 2"),
        ("A1D", ParameterError, "pn", "exactly 3 decimal digits"),
        ("P1234567", ParameterError, "time", "at most 5 digits"),
        ("P832767", ParameterError, "bt", "out of range 0-7"),
        ("K8,00", ParameterError, "dt", "out of range 1-7"),
        ("K0,00", ParameterError, "dt", "out of range 1-7"),
        ("Q99", ParameterError, "s1", "out of range 100-65535"),
        ("E3", ParameterError, "mode", "out of range 0-2"),
        ("216777216", ParameterError, "pp", "24-bit"),
        ("2+12345678", ParameterError, "pp", "at most 7 digits"),
        ("OHX", CommandFormError, "text", "fits no form of OH"),
        ("2D5", CommandFormError, "text", "fits no form of 2"),
        ("END", CommandFormError, "text", "only inside a user program"),
        ("oh4000", UnknownCommandError, "text", "unknown"),
    ],
)
def test_bad_text_is_refused_naming_the_field_and_rule(
    text: str, error: type[Exception], field: str, words: str
) -> None:
    with pytest.raises(error) as caught:
        parse(text)
    assert words in str(caught.value)
    assert caught.value.field == field  # type: ignore[attr-defined]
    assert caught.value.rule  # type: ignore[attr-defined]


def test_a_range_error_states_the_range() -> None:
    with pytest.raises(ParameterError) as caught:
        parse("OS40000")
    assert caught.value.rule == "ss: decimal 1-32767, up to 5 digits"


def test_program_context_reads_the_same_letters_differently() -> None:
    # 'CO1' reads output bit 1 on the host; in a program it is '/CO' printing "1" (§12 /CO).
    assert parse("CO1").key == "CO{bit}"
    assert parse_statement("CO1").key == "/CO{dt}"
    assert parse_statement("").key == "/"
    assert parse_statement("OH8000").key == "OH{hs}"
    with pytest.raises(CommandFormError, match="only by the host"):
        parse_statement("GSS")  # GSS is not usable in a program (EEPROM column ×)
    with pytest.raises(CommandFormError, match="only by the host"):
        parse_statement("GA")  # not a label 'A': the host's auto-start query


def test_positions_follow_the_management_format() -> None:
    assert parse("2-1000").wire() == "2-1000"
    assert parse("2+1000").wire() == "2+1000"
    assert parse("21000").wire() == "21000"
    signed = PositionFormat.SIGNED
    unsigned = PositionFormat.UNSIGNED
    assert parse("2+8388607", positions=signed).params() == {"pp": 8_388_607}
    assert parse("216777215", positions=unsigned).params() == {"pp": 16_777_215}
    with pytest.raises(ParameterError, match=r"outside -8388608\.\.8388607"):
        parse("28388608", positions=signed)
    with pytest.raises(ParameterError, match="unsigned management") as caught:
        parse("2+1000", positions=unsigned)
    assert caught.value.field == "pp"
    # signed management writes every position with its sign (docs/manual-notes.md)
    assert parse("21000", positions=signed).wire() == "2+1000"
    with pytest.raises(ValidationError, match="signed management"):
        REGISTRY.model("2{pp}")(pp=-1, signed=False)


def test_models_refuse_bad_values_when_built() -> None:
    model = REGISTRY.model("OH{hs}")
    with pytest.raises(ValidationError):
        model(hs=0)
    with pytest.raises(ValidationError):
        model(hs=16384)
    with pytest.raises(ValidationError):
        REGISTRY.model("/J{jump}")(jump="A0")  # absolute jumps count from 1
    with pytest.raises(ValidationError):
        REGISTRY.model("/CO{dt}")(dt="a$b")
    with pytest.raises(ValidationError):
        REGISTRY.model("G{lb}")(lb="a")  # the host cannot start at a lower-case label


def test_unknown_keys_and_mnemonics_are_refused() -> None:
    with pytest.raises(UnknownCommandError):
        REGISTRY.model("OH{xx}")
    with pytest.raises(UnknownCommandError):
        REGISTRY.command("ZZ")
    assert REGISTRY.command("OH").title


def test_any_command_is_one_discriminated_json_body() -> None:
    adapter: TypeAdapter[Any] = TypeAdapter(command_union())
    assert adapter.validate_python({"command": "OH{hs}", "hs": 4000}).wire() == "OH4000"
    assert adapter.validate_json('{"command": "2{pp}", "pp": -5}').wire() == "2-5"
    assert adapter.validate_json('{"command": "\\"\\""}').wire() == ""
    with pytest.raises(ValidationError):
        adapter.validate_python({"command": "OH{hs}", "hs": 0})
    with pytest.raises(ValidationError):
        adapter.validate_python({"command": "/END"})  # program-only: not a host command


def test_idempotency_follows_the_effect() -> None:
    def idem(key: str) -> bool:
        return REGISTRY.model(key).form.idempotent

    assert idem("OH") and idem("OH{hs}") and idem("6") and idem("S") and idem("2{pp}")
    for key in ("3", "4", "7", "7*", "0", "B{pn}", "B{dir}", "OHI{id}", "T{time}", "I", "AW"):
        assert not idem(key), key
    for key in ('""', "9", "GSS"):  # reads that clear the device's flags
        assert not idem(key), key
    assert idem("9{bit}")  # the single-bit form clears nothing (§10 9)


def test_motor_suffix_selects_and_motor_arguments_do_not() -> None:
    assert REGISTRY.model("3{mt}").form.selects_motor
    assert REGISTRY.model("F{mt}").form.selects_motor
    for key in ("6{mt}", "QD{mt}", "CLM{mt}", "CI{mt}"):  # §10 F: queries that keep F
        assert not REGISTRY.model(key).form.selects_motor
    assert parse("32").motor == 2
    assert parse("3").motor is None


def test_catalog_facts_are_consistent() -> None:
    for entry in ENTRIES:
        form, spec = entry.form, entry.spec
        if spec.program_only:
            assert form.reply is ReplyFormat.NONE, entry.key
        else:
            assert form.reply is not ReplyFormat.NONE, entry.key
        if form.reply.has_data:
            assert form.effect is Effect.QUERY, entry.key
        if form.effect is Effect.MOTION:
            assert not spec.form_while_moving(form), entry.key
        if form.selects_motor:
            assert form.motor_param == "mt", entry.key


def test_mode_restrictions_inside_a_command() -> None:
    def modes(text: str) -> frozenset[int]:
        command = parse(text)
        return command.spec.form_modes(command.form)

    assert modes("D01B") == {0, 1, 2}
    assert modes("D81B") == {0, 1}  # CLR1 as an output: not in mode 2, use DS (§10 D)
    assert modes("Q") == {0, 1, 2}  # the step-out query
    assert modes("Q400") == modes("QD") == modes("QD1") == {0, 2}  # the period (§10 Q)
    assert modes("PA4") == {0, 1}  # QSE in mode 0 needs PA and PB (§10 QSE)
    with pytest.raises(ParameterError, match="one of 0, 1"):
        parse("D02B")


def test_forms_that_change_state_as_a_side_effect_are_not_resent() -> None:
    for text in ("K1,3F", "K1,3", "KC", "GWT100", "GAS", "EE1", "EL0", "ER1", "SUM1", "SUM0"):
        assert not parse(text).form.idempotent, text
    assert parse("K0").form.idempotent


def test_host_commands_refused_while_a_program_runs() -> None:
    refused = {s.mnemonic for s in REGISTRY.commands if not s.while_program}
    assert refused == {"G", "I", "IL", "IW", "AW", "DW", "AL", "DL"}  # §11-3 5.
