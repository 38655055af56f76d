"""The options of ``rc233-gateway serve`` and ``rc233-gateway sim``: every one they had, and the
options of a simulated loop declared once for both (same type, help, metavar and choices)."""

from __future__ import annotations

import argparse

import pytest

from gateway.cli import build_parser

#: Every option each command has offered (its long form); none may go missing.
SERVE_OPTIONS = {
    "--bodies", "--clock", "--config", "--control", "--eeprom-dir", "--help", "--host",
    "--log-format", "--no-auth", "--port", "--scene", "--simulate", "--time-scale", "--verbose",
}  # fmt: skip
SIM_OPTIONS = {
    "--baud", "--bodies", "--clock", "--control", "--eeprom-dir", "--fault-drop",
    "--fault-garble", "--fault-late", "--fault-nak", "--help", "--late-delay", "--pty", "--scene",
    "--seed", "--series", "--tcp", "--time-scale", "--turnaround-ms", "--verbose",
}  # fmt: skip
#: The options of a simulated loop, which both commands take.
LOOP_OPTIONS = ["--bodies", "--scene", "--eeprom-dir", "--time-scale", "--clock", "--control"]


def _command(name: str) -> argparse.ArgumentParser:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    command: argparse.ArgumentParser = sub.choices[name]
    return command


def _options(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {a.option_strings[-1]: a for a in parser._actions if a.option_strings}


@pytest.mark.parametrize(("name", "expected"), [("serve", SERVE_OPTIONS), ("sim", SIM_OPTIONS)])
def test_every_option_of_serve_and_sim_is_still_there(name: str, expected: set[str]) -> None:
    assert set(_options(_command(name))) == expected


@pytest.mark.parametrize("option", LOOP_OPTIONS)
def test_a_simulated_loop_option_reads_the_same_in_serve_and_sim(option: str) -> None:
    serve, sim = _options(_command("serve"))[option], _options(_command("sim"))[option]
    assert (serve.type, serve.metavar, serve.choices) == (sim.type, sim.metavar, sim.choices)
    assert serve.help == sim.help, "declared twice: the helps drifted apart"
    if option != "--bodies":  # serve simulates a cell of three controllers, sim one
        assert serve.default == sim.default


def test_the_bodies_default_is_parsed_like_a_given_value() -> None:
    parser = build_parser()
    assert parser.parse_args(["serve", "--simulate"]).bodies == ["1", "2", "3"]
    assert parser.parse_args(["sim", "--pty"]).bodies == ["1"]
    assert parser.parse_args(["sim", "--pty", "--bodies", "a,3"]).bodies == ["A", "3"]
    help_text = _command("serve").format_help()
    assert "(default 1,2,3)" in help_text and "(default 1)" in _command("sim").format_help()
