"""The rc233-gateway command line, as a user runs it."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import sys
from pathlib import Path

import pytest
import serial  # type: ignore[import-untyped]

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


async def test_run_serves_the_simulated_loop_on_tcp(tmp_path: Path) -> None:
    """`make run` (until the API exists): the simulator on TCP, reachable as socket://."""
    env = {**os.environ, "XDG_DATA_HOME": str(tmp_path)}  # keep the EEPROM files out of $HOME
    gateway = Path(sys.executable).parent / "rc233-gateway"
    process = await asyncio.create_subprocess_exec(
        str(gateway), "run", stdout=asyncio.subprocess.PIPE, env=env
    )
    assert process.stdout is not None
    try:
        lines: list[str] = []
        while not any("listening on socket://127.0.0.1:5233" in line for line in lines):
            line = await asyncio.wait_for(process.stdout.readline(), 20)
            assert line, "".join(lines)
            lines.append(line.decode())

        def talk() -> tuple[bytes, bytes]:
            port = serial.serial_for_url("socket://127.0.0.1:5233", timeout=5)
            with port:
                port.write(b"$1\r")
                status = port.read(5)
                port.write(b"$3OH\r")
                return status, port.read(9)

        assert await asyncio.to_thread(talk) == (b">$10\r", b">$305000\r")
    finally:
        process.send_signal(signal.SIGTERM)
        assert await asyncio.wait_for(process.wait(), 20) == 0
