"""User programs: the manual's example programs parse, round-trip and jump where its worked
checks say; every program rule refuses with the step GN would show and the rule broken."""

from __future__ import annotations

from collections.abc import Callable
from itertools import pairwise
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gateway.errors import (
    CommandFormError,
    InvalidInputError,
    ParameterError,
    ProgramError,
    UnknownCommandError,
)
from gateway.protocol.command_text import REGISTRY, Context, Entry, parse_statement
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.protocol.program import (
    CAPACITY_BYTES,
    Program,
    ProgramRule,
    Statement,
    parse_program,
    upload_chunks,
)
from gateway.protocol.text_params import Jump
from tests.support.strategies import LABEL_CHARS, LOWER, form_values

# The manual's example programs, verbatim (the project never reads the manual at test time).
CH11_3 = "/0//JON1+1/END/3//END"  # §11-3 note on /END
CH11_4_EX1 = "/D00/0//D01B/JON0+1/J-2/D00/25000/3//END"
CH11_4_EX2 = "/G1/25000/3//END/G2/26000/3//END/G3/27000/3//END"
CH11_4_EX3 = "//EC//22000//3//?//T10//4//?//END"
CH12_SC = "/SCG11/END/G1/D00/SR/END"
CH12_TB = "/TB100/G1//4//JTG11/END"
# Reconstructed from the OCR, see docs/manual-notes.md, "User programs".
CH12_TS = "/TS10/0//22000/3//END"
CH10_GN = "/7/T100/S/END"
# §13-2 ② example 3 sends the program in these two pieces; only the second carries CR.
CH13_2_PIECES = (
    "/E0/OC30/OH8000/OL1000/OS300/OX60/A00130000/CS1,10",
    "/0//B001//1//CD1/JC1+1/J-7/END",
)
CH13_2 = "".join(CH13_2_PIECES)
CH12_JP_NOTE = "/JP2=5000+1/J-2"  # §12 /JP note: a fragment, not a whole program


def refusal(text: str, positions: PositionFormat | None = None) -> ProgramError:
    with pytest.raises(ProgramError) as caught:
        parse_program(text, positions=positions)
    return caught.value


def raised(function: Callable[..., object], *args: object) -> ProgramError:
    with pytest.raises(ProgramError) as caught:
        function(*args)
    return caught.value


def jumps(program: Program) -> dict[int, int]:
    return {s.step: program.target(s.step) for s in program.statements if s.jump is not None}


# --- the manual's programs ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "steps", "labels", "targets"),
    [
        (CH11_3, 7, {}, {3: 5}),
        (CH11_4_EX1, 11, {}, {5: 7, 6: 5}),
        (CH11_4_EX2, 15, {"1": 1, "2": 6, "3": 11}, {}),
        (CH11_4_EX3, 16, {}, {}),
        (CH12_SC, 6, {"1": 3}, {1: 4}),
        (CH12_TB, 7, {"1": 2}, {6: 3}),
        (CH12_TS, 7, {}, {}),
        (CH10_GN, 4, {}, {}),
        (CH13_2, 18, {}, {16: 18, 17: 11}),
    ],
)
def test_manual_programs_parse_round_trip_and_jump_where_the_manual_says(
    text: str, steps: int, labels: dict[str, int], targets: dict[int, int]
) -> None:
    program = parse_program(text)
    assert program.text() == text
    assert program.step_count == steps
    assert program.size_bytes == len(text)
    assert dict(program.labels) == labels
    assert jumps(program) == targets
    assert [s.step for s in program.statements] == list(range(1, steps + 1))
    assert program.statements[-1].is_end


def test_ch11_4_example_1_worked_check() -> None:
    # "⑤ /JON0+1: if input bit 0 is ON, execute the command one beyond the next, /D00 ⑦";
    # "⑥ /J-2: jump to /JON0+1, two commands before the next".
    program = parse_program(CH11_4_EX1)
    assert [s.text() for s in program.statements] == [
        "/D00", "/0", "/", "/D01B", "/JON0+1", "/J-2", "/D00", "/25000", "/3", "/", "/END",
    ]  # fmt: skip
    assert program.statement(5).text() == "/JON0+1"
    assert program.target(5) == 7
    assert program.statement(7).text() == "/D00"
    assert program.target(6) == 5


def test_ch13_2_example_3_worked_check() -> None:
    # Origin /END = 0, /J-7 = -1, /JC1+1 = -2, /CD1 = -3, '/' = -4, /1 = -5, '/' = -6,
    # /B001 = -7: /J-7 lands on /B001 and /JC1+1 (+1 from /J-7 = 0) on /END.
    program = parse_program(CH13_2)
    origin = program.statement(17).step + 1
    chain = ["/END", "/J-7", "/JC1+1", "/CD1", "/", "/1", "/", "/B001"]
    assert [program.statement(origin - k).text() for k in range(8)] == chain
    assert program.statement(program.target(17)).text() == "/B001"
    assert program.statement(program.target(16)).text() == "/END"


def test_gn_counts_the_slashes_up_to_the_statement() -> None:
    # §10 GN: while /7/T100/S/END runs, GN = 3 means /S is next.
    assert parse_program(CH10_GN).statement(3).text() == "/S"
    # '//' is two steps: the command and the NULL wait after it.
    program = parse_program(CH11_4_EX1)
    assert program.statement(2).text() == "/0"
    assert program.statement(3).command.key == "/"
    assert program.statement(4).text() == "/D01B"


def test_ch11_4_example_3_starts_with_a_null_wait() -> None:
    # The first character is '/', as §10 I requires; '//EC' is the NULL wait (step 1)
    # followed by /EC (step 2): nothing before the first '/' is lost.
    program = parse_program(CH11_4_EX3)
    assert program.statement(1).command.key == "/"
    assert program.statement(2).text() == "/EC"
    assert program.statement(16).text() == "/END"
    # Its /? variants of the commentary parse too.
    assert parse_program("//22000//3//?//T10//4//?//END").step_count == 14
    assert parse_program("//22000//3//T10//4//END").step_count == 10


def test_ch11_4_example_2_host_starts() -> None:
    # 'G2' runs from the statement after /G2; 'G' and 'G1' both run the first program.
    program = parse_program(CH11_4_EX2)
    assert program.host_start("1") == 2
    assert program.host_start("2") == 7
    assert program.statement(7).text() == "/26000"
    assert program.host_start("3") == 12


def test_ch13_2_example_3_uploads_in_its_own_two_pieces() -> None:
    program = parse_program(CH13_2)
    assert upload_chunks(program, len(CH13_2_PIECES[0])) == list(CH13_2_PIECES)
    assert upload_chunks(program, CAPACITY_BYTES) == [CH13_2]


@pytest.mark.parametrize(
    ("text", "step", "target"),
    [
        ("/J+1/1/3/END", 1, 3),  # §12 /J: '/J+1' skips the next command
        ("/1/J-2/END", 2, 1),  # §12 /J: '/J-2' the command before (the jump)
        ("/1/3/JA1/END", 3, 1),  # §12 /J: '/JA1' the first command
        ("/Gｱ/1/JGｱ1/END", 3, 2),  # §12 /J: '/JGｱ1' the command after '/Gｱ'
        ("/Gｹ/0/JBONB1Gｹ1/END", 3, 2),  # §12 /JB: the command after label 'ｹ'
        ("/0/1/JBOFA7-3/END", 3, 1),  # §12 /JB: two commands before this one
        ("/JC1A50" + "/0" * 49 + "/END", 1, 50),  # §12 /JC: the 50th command
        ("/G2/0/JC1>300G21/END", 3, 2),  # §12 /JC: to G2
        ("/0/JM-2/END", 2, 1),  # §12 /JM: the command before this one
        ("/G1/0/JON2G11/END", 3, 2),  # §12 /JO: the command after '/G1'
        ("/0/JOF1-1/END", 2, 2),  # §12 /JO: repeat this command
        ("/JON8+3/0/1/3/4/END", 1, 5),  # §12 /JO: three beyond the next command
        ("/G2/0/JONCG21/END", 3, 2),  # §12 /JO: the command after '/G2'
        ("/G2/0/JP1>60000G21/END", 3, 2),  # §12 /JP
        ("/0/1/3/JRB<EEA3/END", 4, 3),  # §12 /JR: the third command
        ("/JRA=RC+5" + "/0" * 6 + "/END", 1, 7),  # §12 /JR: five beyond the next
        ("/TB100/0/JTA2/END", 3, 2),  # §12 /JT: the second command
        ("/J+0/END", 1, 2),  # +0 and -0 are the origin itself: the next statement
        ("/J-0/END", 1, 2),
        ("/J-1/END", 1, 1),  # -1 is the jump itself
    ],
)
def test_ch12_jump_examples_land_where_the_manual_says(text: str, step: int, target: int) -> None:
    assert parse_program(text).target(step) == target


def test_full_width_katakana_of_the_printed_manual_is_not_a_label() -> None:
    # The manual prints 'ア'; labels are half-width (半角文字), 'ｱ' on the wire.
    error = refusal("/Gア/1/JGア1/END")
    assert (error.step, error.field) == (1, "lb")


def test_every_jump_of_chapter_12_has_a_target() -> None:
    with_jump = {
        e.spec.mnemonic
        for e in REGISTRY.entries
        if e.usable_in(Context.PROGRAM) and any(isinstance(p, Jump) for p in e.form.params)
    }
    assert with_jump == {"/J", "/JB", "/JC", "/JE", "/JM", "/JO", "/JP", "/JR", "/JT", "/SC"}
    statements = [
        "J", "JBONA0", "JBOFA0", "JC1", "JC1=5", "JE", "JE0", "JM", "JON0", "JOF0",
        "JP1=0", "JRA=00", "JRA=RB", "JT", "SC",
    ]  # fmt: skip
    for statement in statements:
        program = parse_program(f"/0/{statement}-2/END")
        assert program.statement(2).jump == "-2"
        assert program.target(2) == 1, statement


# --- refusals -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "step", "field", "rule"),
    [
        ("", 0, "text", ProgramRule.EMPTY),
        ("END", 0, "text", ProgramRule.FIRST_CHARACTER),
        ("$1I", 0, "text", ProgramRule.FIRST_CHARACTER),
        (" /END", 0, "text", ProgramRule.FIRST_CHARACTER),
        ("/CO$1/END", 1, "text", ProgramRule.DOLLAR),
        ("/0//G$/END", 3, "text", ProgramRule.DOLLAR),  # §10 I: not even as a label
        ("/END$", 1, "text", ProgramRule.DOLLAR),
        ("/0/END\r", 2, "text", ProgramRule.CR),
        ("/0\r/END", 1, "text", ProgramRule.CR),
        ("/COé/END", 1, "text", ProgramRule.CHARACTERS),
        ("/0/CO漢字/END", 2, "text", ProgramRule.CHARACTERS),
        ("/G1/0//G1/END", 4, "lb", ProgramRule.DUPLICATE_LABEL),
        ("/Ga/0/Ga/END", 3, "lb", ProgramRule.DUPLICATE_LABEL),
        ("/JGz1/END", 1, "jump", ProgramRule.MISSING_LABEL),
        ("/G1/SCG21/END", 2, "jump", ProgramRule.MISSING_LABEL),
        ("/J+1/END", 1, "jump", ProgramRule.OUTSIDE),  # lands on step 3 of 2
        ("/J-2/END", 1, "jump", ProgramRule.OUTSIDE),  # lands on step 0
        ("/0/J-3/END", 2, "jump", ProgramRule.OUTSIDE),
        ("/JA3/END", 1, "jump", ProgramRule.OUTSIDE),
        ("/0/G1/JG13/END", 3, "jump", ProgramRule.OUTSIDE),  # label 2 + 3 = step 5 of 4
        ("/0//3", 3, "text", ProgramRule.END),
        ("/END/0", 2, "text", ProgramRule.END),
        ("/END//", 3, "text", ProgramRule.END),  # a NULL wait after the last /END
        ("/", 1, "text", ProgramRule.END),
        (CH12_JP_NOTE, 2, "text", ProgramRule.END),
    ],
)
def test_program_rules_are_refused_with_step_field_and_rule(
    text: str, step: int, field: str, rule: ProgramRule
) -> None:
    error = refusal(text)
    assert (error.step, error.field, error.rule) == (step, field, rule)
    assert str(error).startswith(f"step {step}: ")


def test_the_last_step_inside_the_program_is_accepted() -> None:
    # The edges of OUTSIDE above: step N and step 1 are targets, N + 1 and 0 are not.
    assert parse_program("/J+0/END").target(1) == 2
    assert parse_program("/0/G1/JG12/END").target(3) == 4
    assert parse_program("/0/J-2/END").target(2) == 1
    assert parse_program("/0/JA3/END").target(2) == 3


@pytest.mark.parametrize(
    ("text", "step", "statement", "error"),
    [
        ("/0//XYZ/END", 3, "XYZ", UnknownCommandError),
        ("/GA/END", 1, "GA", CommandFormError),  # the host query GA, not a label "A"
        ("/0/I/END", 2, "I", CommandFormError),  # host only (§11-3: EEPROM column ×)
        ("/AW/END", 1, "AW", CommandFormError),
        ("/IR/END", 1, "IR", CommandFormError),
        ("/GSS/END", 1, "GSS", CommandFormError),
        ("/OH20000/END", 1, "OH20000", ParameterError),
        ("/0/T40000/END", 2, "T40000", ParameterError),
        ("/J+1000/END", 1, "J+1000", ParameterError),
        ("/JA0/END", 1, "JA0", ParameterError),
        ("/G#/END", 1, "G#", ParameterError),  # bad label characters
        ("/0/GZ/END", 2, "GZ", ParameterError),
        ("/G12/END", 1, "G12", CommandFormError),  # one character only
        ("/JG#1/END", 1, "JG#1", ParameterError),
        ("/0/end", 2, "end", UnknownCommandError),  # commands are upper case
        ("/0/END ", 2, "END ", CommandFormError),
    ],
)
def test_statements_that_do_not_parse_keep_their_field_and_rule(
    text: str, step: int, statement: str, error: type[InvalidInputError]
) -> None:
    with pytest.raises(error) as inner:
        parse_statement(statement)
    wrapped = refusal(text)
    assert wrapped.step == step
    assert (wrapped.field, wrapped.rule) == (inner.value.field, inner.value.rule)
    assert isinstance(wrapped.__cause__, error)
    assert f"/{statement}" in str(wrapped)


def test_positions_are_checked_in_the_controllers_management() -> None:
    assert parse_program("/2-1000/END", positions=PositionFormat.SIGNED).text() == "/2-1000/END"
    error = refusal("/0/2-1000/END", positions=PositionFormat.UNSIGNED)
    assert error.step == 2
    assert isinstance(error.__cause__, ParameterError)
    assert "unsigned management" in str(error)


def test_non_canonical_text_is_written_canonically() -> None:
    assert parse_program("/OH05000/END").text() == "/OH5000/END"


# --- capacity -------------------------------------------------------------------------------


def program_of_size(size: int, filler: str) -> str:
    """A valid program of ``size`` wire bytes: 23-byte /CO statements, NULL waits, /END."""
    body = size - len("/END")
    text = ("/CO" + filler * 20) * (body // 23) + "/" * (body % 23) + "/END"
    assert len(text) == size
    return text


@pytest.mark.parametrize("filler", ["x", "ｱ"])
def test_capacity_is_4416_bytes_exactly(filler: str) -> None:
    fits = program_of_size(CAPACITY_BYTES, filler)
    program = parse_program(fits)
    assert program.size_bytes == CAPACITY_BYTES
    assert program.text() == fits
    over = program_of_size(CAPACITY_BYTES + 1, filler)
    error = refusal(over)
    # The first statement that does not fit is the last one, /END.
    assert (error.step, error.field, error.rule) == (over.count("/"), "text", ProgramRule.CAPACITY)


def test_half_width_katakana_are_one_byte_each() -> None:
    # In UTF-8 this program is about three times as long: counting UTF-8 would refuse it.
    text = program_of_size(CAPACITY_BYTES, "ｱ")
    assert len(text.encode("utf-8")) > CAPACITY_BYTES
    assert parse_program("/Gｱ/CO¥ｱ‾/END").size_bytes == 13


# --- the Program object ---------------------------------------------------------------------


def test_host_start_refuses_lower_case_and_missing_labels() -> None:
    program = parse_program("/Ga/0//G1/3//END")
    assert program.host_start("1") == 5
    error = raised(program.host_start, "a")
    assert (error.step, error.field, error.rule) == (1, "lb", ProgramRule.HOST_LOWER_CASE)
    error = raised(program.host_start, "z")
    assert (error.step, error.rule) == (0, ProgramRule.HOST_LOWER_CASE)
    error = raised(program.host_start, "2")
    assert (error.step, error.field, error.rule) == (0, "lb", ProgramRule.HOST_MISSING)
    # A lower-case label is still a jump target.
    assert parse_program("/Ga/0/JGa1/END").target(3) == 2


def test_target_and_statement_refuse_steps_that_are_not_jumps() -> None:
    program = parse_program(CH11_4_EX1)
    error = raised(program.target, 4)
    assert (error.step, error.field, error.rule) == (4, "step", ProgramRule.NOT_A_JUMP)
    for step in (0, 12):
        error = raised(program.target, step)
        assert (error.step, error.rule) == (step, ProgramRule.STEPS)


def test_statement_properties() -> None:
    label, jump, end = parse_program("/G1/JG11/END").statements
    assert (label.label, label.jump, label.is_end) == ("1", None, False)
    assert (jump.label, jump.jump, jump.is_end) == (None, "G11", False)
    assert (end.label, end.jump, end.is_end) == (None, None, True)
    assert end.text() == "/END"


def test_programs_built_from_commands_are_checked_the_same_way() -> None:
    commands = [parse_statement(s) for s in ("0", "", "J-4", "END")]
    error = raised(Program.from_commands, commands)
    assert (error.step, error.rule) == (3, ProgramRule.OUTSIDE)
    error = raised(Program, ())
    assert (error.step, error.rule) == (0, ProgramRule.EMPTY)
    end = parse_statement("END")
    error = raised(Program, (Statement(2, end),))
    assert (error.step, error.field, error.rule) == (1, "step", ProgramRule.STEPS)
    assert Program.from_commands([end]) == parse_program("/END")


def test_programs_are_frozen_and_hashable() -> None:
    program = parse_program(CH12_SC)
    with pytest.raises(AttributeError):
        program.statements = ()  # type: ignore[misc]
    with pytest.raises(TypeError):
        program.labels["9"] = 1  # type: ignore[index]
    assert hash(program) == hash(parse_program(CH12_SC))


def test_upload_chunks_refuses_an_empty_chunk_size() -> None:
    with pytest.raises(ValueError, match="at least 1"):
        upload_chunks(parse_program("/END"), 0)


# --- generated programs ---------------------------------------------------------------------

PROGRAM_ENTRIES = [e for e in REGISTRY.entries if e.usable_in(Context.PROGRAM)]
JUMP_ENTRIES = [e for e in PROGRAM_ENTRIES if any(isinstance(p, Jump) for p in e.form.params)]
LABEL_MODEL = REGISTRY.model("/G{lb}")
PLAIN_ENTRIES = [e for e in PROGRAM_ENTRIES if e not in JUMP_ENTRIES and e.key != "/G{lb}"]


def _jump_name(entry: Entry) -> str:
    return next(p.name for p in entry.form.params if isinstance(p, Jump))


@st.composite
def programs(draw: st.DrawFn) -> tuple[list[Command], dict[str, int], dict[int, int]]:
    """Valid statements, a unique label per label statement, jumps to drawn targets, /END."""
    kinds = draw(st.lists(st.sampled_from(["plain", "label", "jump"]), min_size=0, max_size=30))
    names = iter(
        draw(
            st.lists(
                st.sampled_from(LABEL_CHARS + LOWER),
                unique=True,
                min_size=kinds.count("label"),
                max_size=kinds.count("label"),
            )
        )
    )
    count = len(kinds) + 1  # + /END
    labels = {next(names): step for step, kind in enumerate(kinds, 1) if kind == "label"}
    by_step = {step: name for name, step in labels.items()}
    commands: list[Command] = []
    targets: dict[int, int] = {}
    for step, kind in enumerate(kinds, 1):
        if kind == "label":
            commands.append(LABEL_MODEL.model_validate({"lb": by_step[step]}))
            continue
        entry = draw(st.sampled_from(JUMP_ENTRIES if kind == "jump" else PLAIN_ENTRIES))
        values: dict[str, Any] = draw(form_values(entry))
        if kind == "jump":
            target = draw(st.integers(1, count))
            operands = [f"A{target}"]
            operands += [f"+{target - step - 1}"] if target > step else []
            operands += [f"-{step + 1 - target}"] if target <= step + 1 else []
            operands += [f"G{n}{target - s}" for n, s in labels.items() if s < target]
            values[_jump_name(entry)] = draw(st.sampled_from(operands))
            targets[step] = target
        commands.append(entry.model(**values))
    commands.append(parse_statement("END"))
    return commands, labels, targets


@settings(max_examples=200, deadline=None)
@given(programs())
def test_generated_programs_round_trip_through_text(
    generated: tuple[list[Command], dict[str, int], dict[int, int]],
) -> None:
    commands, labels, targets = generated
    text = "".join("/" + c.wire() for c in commands)
    program = parse_program(text)
    assert program.text() == text
    assert [s.command for s in program.statements] == commands
    assert program == Program.from_commands(commands)
    assert dict(program.labels) == labels
    assert jumps(program) == targets
    assert program.step_count == len(commands)
    # Each statement's step is the number of '/' up to and including its own (§10 GN).
    offset = 0
    for statement in program.statements:
        offset += len(statement.text())
        assert text[:offset].count("/") == statement.step


@settings(max_examples=100, deadline=None)
@given(programs(), st.integers(1, 40))
def test_upload_chunks_cover_the_text_in_pieces_without_cr(
    generated: tuple[list[Command], dict[str, int], dict[int, int]], max_chunk: int
) -> None:
    program = Program.from_commands(generated[0])
    chunks = upload_chunks(program, max_chunk)
    assert "".join(chunks) == program.text()
    assert all(1 <= len(c) <= max_chunk and "\r" not in c for c in chunks)
    if max_chunk >= max(len(s.text()) for s in program.statements):
        # Whole statements per piece, and no piece could have taken the next statement.
        assert all(c.startswith("/") for c in chunks)
        assert all(len(a) + len(b.split("/")[1]) + 1 > max_chunk for a, b in pairwise(chunks))


@pytest.mark.parametrize(
    ("text", "detail"),
    [
        (
            "/D00/J+5/END",
            "step 2: '/J+5' lands on step 8 (5 on from step 3, the statement after it), "
            "but the program has steps 1-3 only",
        ),
        (
            "/J-2/END",
            "step 1: '/J-2' lands on step 0 (2 back from step 2, the statement after it), "
            "but the program has steps 1-2 only",
        ),
        (
            "/JA3/END",
            "step 1: '/JA3' lands on step 3 (step 3 counted from the first statement), "
            "but the program has steps 1-2 only",
        ),
        (
            "/0/G1/JG13/END",
            "step 3: '/JG13' lands on step 5 (3 on from label '1' at step 2), "
            "but the program has steps 1-4 only",
        ),
    ],
)
def test_a_jump_outside_names_the_statement_the_target_and_how_it_was_counted(
    text: str, detail: str
) -> None:
    assert str(refusal(text)) == detail
