"""The rc233-gateway command line, as a user runs it."""

from __future__ import annotations

import json

import pytest

from gateway.cli import main

from .protocol.test_registry import CHAPTER_10, CHAPTER_12


def test_catalog_json_names_every_mnemonic(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["catalog", "--json"]) == 0
    catalog = json.loads(capsys.readouterr().out)
    names = ['""' if c["mnemonic"] == "" else c["mnemonic"] for c in catalog]
    assert sorted(names) == sorted(CHAPTER_10 + CHAPTER_12)
    oh = next(c for c in catalog if c["mnemonic"] == "OH")
    assert oh["scope"] == "per_motor"
    assert oh["modes"] == [0, 1, 2]
    assert oh["while_moving"] is True
    assert oh["user_program"] is True
    assert oh["idempotent"] is True
    assert oh["forms"][0]["syntax"] == "OH{hs}"
    assert oh["forms"][0]["params"][0] == {
        "name": "hs",
        "kind": "Dec",
        "rule": "hs: decimal 1-16383, up to 5 digits",
        "min": 1,
        "max": 16383,
        "digits": 5,
        "exact_digits": False,
    }
    assert {f["syntax"]: f["idempotent"] for f in oh["forms"]}["OHI{id}"] is False
    assert any(c["mnemonic"] == "/JC" for c in catalog)


def test_catalog_table_has_a_line_per_form(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["catalog"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:3] == ["mnemonic", "form", "reply"]
    assert any(line.split()[:2] == ["OH", "OH{hs}"] for line in lines)


def test_parse_prints_the_typed_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["parse", "B0012"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["command"] == "B{pn}{mt}"
    assert out["params"] == {"pn": 1, "mt": 2}
    assert out["idempotent"] is False


def test_parse_refuses_bad_text_with_the_rule(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["parse", "OH99999"]) == 2
    err = capsys.readouterr().err
    assert "out of range 1-16383" in err
    assert "field: hs" in err


def test_parse_in_program_context_and_with_positions(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["parse", "--program", "JC1+1"]) == 0
    assert json.loads(capsys.readouterr().out)["command"] == "/JC{ct}{jump}"
    assert main(["parse", "--positions", "signed", "21000"]) == 0
    assert json.loads(capsys.readouterr().out)["wire"] == "2+1000"


def test_run_says_what_is_missing(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run"]) == 0
    assert "simulated RC-233 loop" in capsys.readouterr().out
