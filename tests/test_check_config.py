"""``rc233-gateway check-config``: every problem of a file named by its key, nothing started."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from gateway.api.security import hash_token
from gateway.cli import main
from tests.support.config_checks import problems_of, pseudo_terminal

EXAMPLE = Path(__file__).parents[1] / "deploy" / "cell.example.toml"


@pytest.fixture
def tty() -> Iterator[str]:
    with pseudo_terminal() as path:
        yield path


def cell(tmp_path: Path, *, audit: str, port: str, tokens: bool = True) -> Path:
    lines = [
        f'audit_log = "{audit}"',
        "[[loops]]",
        'name = "main"',
        f'port = "{port}"',
        "[[loops.controllers]]",
        'body = "1"',
    ]
    if tokens:
        lines += [
            "[[security.tokens]]",
            'name = "mes"',
            'role = "operator"',
            f'sha256 = "{hash_token("tok-mes")}"',
        ]
    path = tmp_path / "cell.toml"
    path.write_text("\n".join(lines) + "\n", "utf-8")
    return path


def test_the_example_fails_naming_every_problem_by_its_key(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert not Path("/var/log/rc233-gateway").exists(), "this test needs the directory absent"
    assert main(["check-config", str(EXAMPLE)]) == 1
    out = capsys.readouterr().out
    found = problems_of(out)
    assert set(found) == {
        "security.tokens[0].sha256",
        "security.tokens[1].sha256",
        "audit_log",
    }, out
    assert "/var/log/rc233-gateway does not exist" in found["audit_log"]
    assert out.startswith(f"{EXAMPLE}: 3 problem(s)")
    # The adapter of the example is not plugged in here: a warning (that loop starts down)
    warned = problems_of(out, "warning(s)")
    assert list(warned) == ["loops[0].port"], out
    assert "No such file or directory" in warned["loops[0].port"]


def test_a_good_file_is_ok(tmp_path: Path, tty: str, capsys: pytest.CaptureFixture[str]) -> None:
    path = cell(tmp_path, audit=str(tmp_path / "audit.jsonl"), port=tty)
    assert main(["check-config", str(path)]) == 0
    assert capsys.readouterr().out == f"{path}: ok (1 loop(s), 1 controller(s), 1 token(s))\n"
    assert not (tmp_path / "audit.jsonl").exists()  # checked, not made


@pytest.mark.parametrize(
    ("audit", "port", "key", "words"),
    [
        ("{tmp}/none/audit.jsonl", "{tty}", "audit_log", "does not exist"),
        ("{tmp}", "{tty}", "audit_log", "is a directory"),
        ("{tmp}/a.jsonl", "/dev/null", "loops[0].port", "a character device but not a terminal"),
        ("{tmp}/a.jsonl", "/dev/zero", "loops[0].port", "a character device but not a terminal"),
        ("{tmp}/a.jsonl", "{tmp}/cell.toml", "loops[0].port", "not a serial device"),
        ("{tmp}/a.jsonl", "socket://host", "loops[0].port", "socket://HOST:PORT"),
        ("{tmp}/a.jsonl", "socket://host:70000", "loops[0].port", "port 1-65535"),
        ("{tmp}/a.jsonl", "dev/ttyUSB0", "loops[0].port", "must be absolute"),
    ],
)
def test_each_site_problem_is_named_by_its_key(
    tmp_path: Path,
    tty: str,
    capsys: pytest.CaptureFixture[str],
    audit: str,
    port: str,
    key: str,
    words: str,
) -> None:
    path = cell(tmp_path, audit=audit.format(tmp=tmp_path), port=port.format(tmp=tmp_path, tty=tty))
    assert main(["check-config", str(path)]) == 1
    found = problems_of(capsys.readouterr().out)
    assert list(found) == [key]
    assert words in found[key]


def test_a_missing_device_is_a_warning_and_a_problem_when_strict(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # An adapter unplugged at boot: that loop starts down, the others serve.
    path = cell(tmp_path, audit=str(tmp_path / "a.jsonl"), port="/dev/serial/by-id/not-here")
    assert main(["check-config", str(path)]) == 0
    out = capsys.readouterr().out
    assert problems_of(out) == {}, out
    warned = problems_of(out, "warning(s)")
    assert list(warned) == ["loops[0].port"], out
    assert "does not exist yet (No such file or directory)" in warned["loops[0].port"]
    assert "the loop starts down" in warned["loops[0].port"]
    assert out.endswith(f"{path}: ok (1 loop(s), 1 controller(s), 1 token(s))\n")
    assert main(["check-config", "--strict", str(path)]) == 1
    out = capsys.readouterr().out
    assert list(problems_of(out)) == ["loops[0].port"], out
    assert problems_of(out, "warning(s)") == {}


def test_no_token_is_a_problem_unless_the_api_runs_open(
    tmp_path: Path, tty: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = cell(tmp_path, audit=str(tmp_path / "a.jsonl"), port=tty, tokens=False)
    assert main(["check-config", str(path)]) == 1
    assert "security.tokens: no API token is configured" in capsys.readouterr().out
    assert main(["check-config", str(path), "--no-auth"]) == 0


def test_serve_refuses_to_start_with_any_problem_left(
    tmp_path: Path, tty: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = cell(tmp_path, audit=str(tmp_path / "missing" / "audit.jsonl"), port=tty)
    assert main(["serve", "--config", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}: 1 problem(s)" in err
    assert "audit_log: the directory" in err
