"""The typed command constructors build exactly what ``parse`` builds from the same text.

Checked two ways: every constructor against the canonical text of its form, and every frame of
the manual's own examples (tests/support/manual_examples.py) whose form has a constructor, rebuilt
from its parsed parameters.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

import pytest

from gateway.errors import InvalidInputError, ParameterError
from gateway.protocol import Command, PositionFormat, commands, parse
from gateway.protocol.spec import Effect
from tests.support.manual_examples import EXAMPLES, NEEDS_CONTROL

SIGNED = PositionFormat.SIGNED
UNSIGNED = PositionFormat.UNSIGNED

#: (constructor, positional arguments, the text ``parse`` must turn into the same model)
CASES: list[tuple[str, tuple[Any, ...], str]] = [
    ("status", (), ""),
    ("condition", (), "9"),
    ("condition_bit", (7,), "97"),
    ("condition_bit", (4,), "94"),
    ("version", (), "V"),
    ("mode", (), "E"),
    ("set_mode", (1,), "E1"),
    ("selected_motor", (), "F"),
    ("select_motor", (2,), "F2"),
    ("position", (), "6"),
    ("position", (1,), "61"),
    ("position_format", (), "EP"),
    ("set_position_format", (True,), "EP1"),
    ("set_position_format", (False,), "EP0"),
    ("set_position_data", (1250,), "21250"),
    ("position_data", (), "2D"),
    ("table_entry", (13,), "A013D"),
    ("set_table_entry", (13, 300), "A013300"),
    ("move_to_position_data", (), "3"),
    ("move_to_position_data", (2,), "32"),
    ("move_cw", (), "4"),
    ("move_ccw", (1,), "51"),
    ("home", (), "0"),
    ("home", ("0Z",), "0Z"),
    ("home", ("0R",), "0R"),
    ("jog_cw", (), "7"),
    ("jog_ccw", (2,), "82"),
    ("jog_high", (), "H"),
    ("jog_low", (), "L"),
    ("step_cw", (), "7*"),
    ("step_ccw", (), "8*"),
    ("stop", (), "S"),
    ("slow_stop", (), "SS"),
    ("speed", ("OX",), "OX"),
    ("set_speed", ("OH", 4000), "OH4000"),
    ("set_speed", ("OL", 200), "OL200"),
    ("set_speed", ("OS", 32767), "OS32767"),
    ("set_speed", ("OC", 0), "OC0"),
    ("set_speed", ("OX", 2), "OX2"),
    ("inputs", (), "C"),
    ("inputs_with_inp", (), "CA"),
    ("outputs", (), "CO"),
    ("outputs_with_clr", (), "COA"),
    ("sensors", (), "CL"),
    ("sensors", (2,), "CLM2"),
    ("sensor_logic", (), "EA"),
    ("error_output", (), "K"),
    ("echo_back", (), "EE"),
    ("set_echo_back", (True,), "EE1"),
    ("cr_after_ack", (), "EL"),
    ("set_cr_after_ack", (False,), "EL0"),
    ("error_mark", (), "ER"),
    ("set_error_mark", (True,), "ER1"),
    ("checksum", (), "SUM"),
    ("set_checksum", (False,), "SUM0"),
    ("baud_rate", (), "ES"),
    ("set_baud_rate", (1,), "ES1"),
    ("load_settings", (), "DL"),
    ("upload_program", (), "I"),
    ("program_text", (), "IR"),
    ("run_program", (), "G"),
    ("run_program", ("1",), "G1"),
    ("program_state", (), "GSS"),
    ("next_step", (), "GN"),
    ("program_buffer", ("C",), "GRC"),
    ("program_counter", (2,), "GR2"),
    ("program_autostart", (), "GA"),
    ("end_program", (), "GE"),
    ("pause_program", (), "GS"),
    ("resume_program", (), "GC"),
    ("set_program_autostart", (True,), "GAS"),
    ("set_program_autostart", (False,), "GAR"),
    ("end_program_now", (), "GES"),
    ("store_position", (12,), "A012"),
    ("input_bit", (3,), "C3"),
    ("input_bit", (8,), "C8"),
    ("output_bit", (9,), "CO9"),
    ("set_outputs", (0x5A,), "D5A"),
    ("set_outputs", (0x5A, (True, True)), "DA35A"),
    ("set_outputs", (0x01, (False, True)), "DA201"),
    ("set_output_bit", (3, False), "D30B"),
    ("set_output_bit", (8, True), "D81B"),
    ("set_output_bit", (9, False), "D90B"),
    ("pulse_output", (3, 10), "P310"),
    ("set_sensor_logic", (0x3F,), "EA3F"),
    ("save_settings", (), "DW"),
    ("save_positions", (), "AW"),
    ("save_program", (), "IW"),
    ("load_positions", (), "AL"),
    ("load_program", (), "IL"),
    ("erase_eeprom", (), "EE///"),
    ("set_program_buffer", ("B", 0x5A), "GWB5A"),
    ("set_program_counter", (2, 65535), "GW265535"),
]


@pytest.mark.parametrize(("name", "args", "text"), CASES, ids=[c[2] or '""' for c in CASES])
def test_each_constructor_builds_what_parse_builds(
    name: str, args: tuple[Any, ...], text: str
) -> None:
    built = getattr(commands, name)(*args)
    assert built == parse(text)
    assert type(built) is type(parse(text))
    assert built.wire() == text


def test_every_constructor_has_a_case() -> None:
    public = {
        name
        for name in commands.__all__
        if inspect.isfunction(getattr(commands, name)) and not name[0].isupper()
    }
    assert public == {name for name, _, _ in CASES}


@pytest.mark.parametrize(
    ("pulses", "fmt", "text"),
    [
        (1250, UNSIGNED, "21250"),
        (1250, SIGNED, "2+1250"),
        (-40, SIGNED, "2-40"),
        (-40, None, "2-40"),
    ],
)
def test_position_data_writes_the_sign_of_the_management(
    pulses: int, fmt: PositionFormat | None, text: str
) -> None:
    built = commands.set_position_data(pulses, fmt)
    assert built == parse(text, positions=fmt)
    assert built.wire() == text


def test_a_broken_argument_names_its_field_and_rule_as_parse_does() -> None:
    with pytest.raises(ParameterError) as by_name:
        commands.set_speed("OH", 16384)
    with pytest.raises(ParameterError) as by_text:
        parse("OH16384")
    assert (by_name.value.field, by_name.value.rule) == (by_text.value.field, by_text.value.rule)
    with pytest.raises(ParameterError, match="unsigned"):
        commands.set_position_data(-1, UNSIGNED)


#: How to rebuild a parsed command of the manual with its constructor, by form key.
_MOTOR: Callable[[Command], Any] = lambda c: c.params().get("mt")  # noqa: E731
REBUILD: dict[str, Callable[[Command], Command]] = {
    '""': lambda c: commands.status(),
    "9": lambda c: commands.condition(),
    "9{bit}": lambda c: commands.condition_bit(c.params()["bit"]),
    "V": lambda c: commands.version(),
    "E": lambda c: commands.mode(),
    "E{mode}": lambda c: commands.set_mode(c.params()["mode"]),
    "F": lambda c: commands.selected_motor(),
    "F{mt}": lambda c: commands.select_motor(c.params()["mt"]),
    "6": lambda c: commands.position(),
    "6{mt}": lambda c: commands.position(_MOTOR(c)),
    "EP": lambda c: commands.position_format(),
    "EP1": lambda c: commands.set_position_format(True),
    "2{pp}": lambda c: commands.set_position_data(
        c.params()["pp"], signed=bool(getattr(c, "signed", False))
    ),
    "2D": lambda c: commands.position_data(),
    "A{pn}D": lambda c: commands.table_entry(c.params()["pn"]),
    "A{pn}{pp}": lambda c: commands.set_table_entry(
        c.params()["pn"], c.params()["pp"], signed=bool(getattr(c, "signed", False))
    ),
    "3{mt}": lambda c: commands.move_to_position_data(_MOTOR(c)),
    "4": lambda c: commands.move_cw(),
    "4{mt}": lambda c: commands.move_cw(_MOTOR(c)),
    "5": lambda c: commands.move_ccw(),
    "0": lambda c: commands.home("0"),
    "0A": lambda c: commands.home("0A"),
    "0H": lambda c: commands.home("0H"),
    "0Z": lambda c: commands.home("0Z"),
    "7": lambda c: commands.jog_cw(),
    "8": lambda c: commands.jog_ccw(),
    "7*": lambda c: commands.step_cw(),
    "8*": lambda c: commands.step_ccw(),
    "H": lambda c: commands.jog_high(),
    "L": lambda c: commands.jog_low(),
    "S": lambda c: commands.stop(),
    "SS": lambda c: commands.slow_stop(),
    "OH": lambda c: commands.speed("OH"),
    "OL": lambda c: commands.speed("OL"),
    "OS": lambda c: commands.speed("OS"),
    "OC": lambda c: commands.speed("OC"),
    "OX": lambda c: commands.speed("OX"),
    "OH{hs}": lambda c: commands.set_speed("OH", c.params()["hs"]),
    "OL{ls}": lambda c: commands.set_speed("OL", c.params()["ls"]),
    "OC{dt}": lambda c: commands.set_speed("OC", c.params()["dt"]),
    "OX{xs}": lambda c: commands.set_speed("OX", c.params()["xs"]),
    "C": lambda c: commands.inputs(),
    "CO": lambda c: commands.outputs(),
    "CL": lambda c: commands.sensors(),
    "EA": lambda c: commands.sensor_logic(),
    "K": lambda c: commands.error_output(),
    "EE": lambda c: commands.echo_back(),
    "EE0": lambda c: commands.set_echo_back(False),
    "EE1": lambda c: commands.set_echo_back(True),
    "EL": lambda c: commands.cr_after_ack(),
    "EL0": lambda c: commands.set_cr_after_ack(False),
    "EL1": lambda c: commands.set_cr_after_ack(True),
    "ER": lambda c: commands.error_mark(),
    "ER0": lambda c: commands.set_error_mark(False),
    "ER1": lambda c: commands.set_error_mark(True),
    "SUM": lambda c: commands.checksum(),
    "SUM1": lambda c: commands.set_checksum(True),
    "ES": lambda c: commands.baud_rate(),
    "ES{bp}": lambda c: commands.set_baud_rate(c.params()["bp"]),
    "DL": lambda c: commands.load_settings(),
    "GA": lambda c: commands.program_autostart(),
}


def _manual_commands() -> list[Command]:
    found: list[Command] = []
    for example in (*EXAMPLES, *NEEDS_CONTROL):
        for step in example.steps:
            frame = step.send
            if len(frame) < 3 or not frame.startswith(b"$") or not frame.endswith(b"\r"):
                continue
            try:
                found.append(parse(frame[2:-1].decode("latin-1")))
            except InvalidInputError:  # a checksummed or '#' frame is no plain command text
                continue
    return found


def test_the_manual_examples_rebuilt_by_name_are_the_same_models() -> None:
    checked: set[str] = set()
    for command in _manual_commands():
        rebuild = REBUILD.get(command.key)
        if rebuild is None:
            continue
        again = rebuild(command)
        assert again == command, command.key
        assert again.wire() == command.wire(), command.key
        checked.add(command.key)
    # every rebuild rule met a frame of the manual: the table is not checking nothing
    assert checked == set(REBUILD)


def test_form_predicates_are_facts_of_the_catalog() -> None:
    framing = {e.key for e in _host_entries() if e.form.switches_framing}
    assert framing == {"EE1", "EE0", "EL1", "EL0", "ER1", "ER0", "SUM1", "SUM0"}
    stops = {e.key for e in _host_entries() if e.form.is_stop}
    assert stops == {"S", "SS", "GES"}
    reads = {e.key for e in _host_entries() if e.form.reads_position}
    assert reads == {"6", "6{mt}"}
    assert commands.select_motor(1).form is commands.SELECT_MOTOR
    assert commands.selected_motor().form is commands.SELECTED_MOTOR
    assert commands.status().form is commands.STATUS
    assert parse("E2").form is commands.SET_MODE
    assert {f.syntax for f in commands.CLEARS_ERRORS} == {"K{dt},{du}{dl}", "K{dt},{bt}", "KC"}
    # the motions whose end the soft limits work out: each one a motion of the catalog
    moves = {
        f: parse(text).form
        for f, text in [
            (commands.MOVES_TO_POSITION_DATA, "31"),
            (commands.MOVES_BY_TABLE_ENTRY, "B012+"),
            (commands.MOVES_TO_TABLE_ENTRY, "B0122"),
            (commands.MOVES_TO_ORIGIN, "1"),
            (commands.ORIGIN_SEARCHES, "0Q"),
        ]
    }
    assert all(form in forms for forms, form in moves.items())
    assert commands.MOVES_BY_POSITION_DATA[parse("52").form] == -1
    assert commands.ONE_PULSE_STEPS[commands.step_cw().form] == 1
    every = (
        *commands.MOVES_TO_POSITION_DATA,
        *commands.MOVES_BY_POSITION_DATA,
        *commands.MOVES_TO_TABLE_ENTRY,
        *commands.MOVES_BY_TABLE_ENTRY,
        *commands.MOVES_TO_ORIGIN,
        *commands.ONE_PULSE_STEPS,
        *commands.ORIGIN_SEARCHES,
    )
    assert all(f.effect is Effect.MOTION for f in every)


def _host_entries() -> list[Any]:
    from gateway.protocol import REGISTRY, Context

    return [e for e in REGISTRY.entries if e.usable_in(Context.HOST)]
