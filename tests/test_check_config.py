"""``rc233-gateway check-config``: every problem of a file named by its key, nothing started."""

from __future__ import annotations

from pathlib import Path

import pytest

from gateway.api.security import hash_token
from gateway.cli import main

EXAMPLE = Path(__file__).parents[1] / "deploy" / "cell.example.toml"


def cell(tmp_path: Path, *, audit: str, port: str = "/dev/null", tokens: bool = True) -> Path:
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


def problems_of(out: str) -> dict[str, str]:
    """The problems printed, by key."""
    found: dict[str, str] = {}
    for line in out.splitlines()[1:]:
        key, _, text = line.strip().partition(": ")
        found.setdefault(key, text)
    return found


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
        "loops[0].port",
    }, out
    assert "/var/log/rc233-gateway does not exist" in found["audit_log"]
    assert "No such file or directory" in found["loops[0].port"]
    assert out.startswith(f"{EXAMPLE}: 4 problem(s)")


def test_a_good_file_is_ok(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = cell(tmp_path, audit=str(tmp_path / "audit.jsonl"))
    assert main(["check-config", str(path)]) == 0
    assert capsys.readouterr().out == f"{path}: ok (1 loop(s), 1 controller(s), 1 token(s))\n"
    assert not (tmp_path / "audit.jsonl").exists()  # checked, not made


@pytest.mark.parametrize(
    ("audit", "port", "key", "words"),
    [
        ("{tmp}/none/audit.jsonl", "/dev/null", "audit_log", "does not exist"),
        ("{tmp}", "/dev/null", "audit_log", "is a directory"),
        ("{tmp}/a.jsonl", "/dev/ttyNOPE9", "loops[0].port", "No such file or directory"),
        ("{tmp}/a.jsonl", "{tmp}/cell.toml", "loops[0].port", "not a serial device"),
        ("{tmp}/a.jsonl", "socket://host", "loops[0].port", "socket://HOST:PORT"),
        ("{tmp}/a.jsonl", "socket://host:70000", "loops[0].port", "port 1-65535"),
        ("{tmp}/a.jsonl", "dev/ttyUSB0", "loops[0].port", "must be absolute"),
    ],
)
def test_each_site_problem_is_named_by_its_key(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    audit: str,
    port: str,
    key: str,
    words: str,
) -> None:
    path = cell(tmp_path, audit=audit.format(tmp=tmp_path), port=port.format(tmp=tmp_path))
    assert main(["check-config", str(path)]) == 1
    found = problems_of(capsys.readouterr().out)
    assert list(found) == [key]
    assert words in found[key]


def test_no_token_is_a_problem_unless_the_api_runs_open(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = cell(tmp_path, audit=str(tmp_path / "a.jsonl"), tokens=False)
    assert main(["check-config", str(path)]) == 1
    assert "security.tokens: no API token is configured" in capsys.readouterr().out
    assert main(["check-config", str(path), "--no-auth"]) == 0


def test_serve_refuses_to_start_with_any_problem_left(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = cell(tmp_path, audit=str(tmp_path / "missing" / "audit.jsonl"))
    assert main(["serve", "--config", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}: 1 problem(s)" in err
    assert "audit_log: the directory" in err
