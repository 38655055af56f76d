"""The rc233-gateway command line, as a user runs it."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import sys
from pathlib import Path

import httpx
import pytest

from gateway.cli import main
from tests.support.manual_chapters import CHAPTER_10, CHAPTER_12


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


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


async def test_make_run_serves_the_api_on_a_simulated_loop(tmp_path: Path) -> None:
    """`make run` is `serve --simulate --no-auth` on 127.0.0.1:8233 (here on a free port): no
    file, no token on loopback, the three simulated controllers' axes listed by name."""
    makefile = (Path(__file__).parents[1] / "Makefile").read_text()
    assert "rc233-gateway serve --simulate --no-auth --host 127.0.0.1 --port 8233" in makefile
    env = {**os.environ, "XDG_DATA_HOME": str(tmp_path)}  # keep the EEPROM files out of $HOME
    gateway = Path(sys.executable).parent / "rc233-gateway"
    port = _free_port()
    process = await asyncio.create_subprocess_exec(
        str(gateway), "serve", "--simulate", "--no-auth", "--port", str(port),
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE, env=env,
    )  # fmt: skip
    assert process.stderr is not None
    try:
        lines: list[str] = []
        while not any("Uvicorn running on" in line for line in lines):
            line = await asyncio.wait_for(process.stderr.readline(), 30)
            assert line, "".join(lines)
            lines.append(line.decode())
        assert any("AUTHENTICATION IS OFF" in line for line in lines), "".join(lines)
        async with httpx.AsyncClient(base_url=f"http://127.0.0.1:{port}") as client:
            reply = await client.get("/api/v1/axes")
        assert reply.status_code == 200
        names = [axis["name"] for axis in reply.json()]
        assert names == ["x", "y", "z", "theta", "gripper", "conveyor"]
    finally:
        process.send_signal(signal.SIGINT)
        assert await asyncio.wait_for(process.wait(), 30) == 0


def test_serve_refuses_an_open_api_off_loopback(capsys: pytest.CaptureFixture[str]) -> None:
    # --simulate off loopback without tokens: auth stays on, and nobody could use it.
    assert main(["serve", "--simulate", "--host", "0.0.0.0"]) == 2
    err = capsys.readouterr().err
    assert "--host 0.0.0.0: no API token is configured, so nobody could use the API" in err
    assert main(["serve", "--simulate", "--host", "0.0.0.0", "--no-auth"]) == 2
    err = capsys.readouterr().err
    assert "--no-auth is only allowed when bound to loopback, not '0.0.0.0'" in err


def test_serve_runs_open_only_with_no_auth(capsys: pytest.CaptureFixture[str]) -> None:
    # One rule for a file and for --simulate: no token and no --no-auth is refused, on
    # loopback too, before anything starts.
    assert main(["serve", "--simulate"]) == 2
    err = capsys.readouterr().err
    assert "security.tokens: no API token is configured" in err
    assert "serve --no-auth" in err
    assert main(["serve"]) == 2
    assert "give --config FILE, --simulate, or both" in capsys.readouterr().err


def test_serve_help_says_the_one_auth_rule(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["serve", "--help"])
    out = " ".join(capsys.readouterr().out.replace("`", "").split())
    assert (
        "every request needs a token of the configuration unless the API is started with "
        "--no-auth, which is accepted only on loopback" in out
    )
    readme = " ".join((Path(__file__).parents[1] / "README.md").read_text().split())
    assert (
        "every request needs a token of the configuration unless the API is started with "
        "`--no-auth`, which is accepted only on loopback" in readme
    )
    example = (Path(__file__).parents[1] / "deploy" / "cell.example.toml").read_text()
    assert "Every request needs a token; the API runs open only when `serve --no-auth`" in example


def test_serve_stops_on_a_bad_configuration(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cell = tmp_path / "cell.toml"
    cell.write_text('[[loops]]\nname = "main"\nport = "socket://127.0.0.1:4001"\nbaud = 4800\n'
                    '[[loops.controllers]]\nbody = "1"\n')  # fmt: skip
    assert main(["serve", "--config", str(cell)]) == 2
    err = capsys.readouterr().err
    assert f"{cell}: 1 problem(s)" in err and "loops[0]: Value error, baud 4800" in err


def test_token_prints_the_configuration_lines(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["token", "--name", "mes", "--role", "operator", "--token", "123456"]) == 0
    out = capsys.readouterr().out
    # sha256("123456"), as any sha256 tool prints it
    assert 'sha256 = "8d969eef6ecad3c29a3a629280e686cf0c3f5d5a86aff3ca12020c923adc6c92"' in out
    assert 'role = "operator"' in out
