"""Configurations that cannot lie: what a hand-edited or hostile file gets from check-config.

Every float finite, every port a terminal used by one loop, and a file read with bounds before
the TOML parser sees it: no file makes ``check-config`` or ``serve`` run out of memory or
time, and a file of a thousand mistakes prints fifty of them and the count of the rest.
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
import tracemalloc
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from gateway.cli import main
from tests.support.config_checks import problems_of, pseudo_terminal

GATEWAY = Path(sys.executable).parent / "rc233-gateway"
LOOP = """
[[loops]]
name = "{name}"
port = "{port}"
[[loops.controllers]]
body = "1"
"""
AXIS = """
[[loops.controllers.axes]]
motor = 1
unit = "mm"
{key} = {value}
"""
#: What one check may cost in this process (CPU seconds, traced allocations), generous for a
#: busy machine: a bounded file needs well under a second; the unbounded parser needed 112 s
#: and 24 GB for one of them.
CPU_BUDGET = 15.0
MEMORY_BUDGET = 64 << 20


@pytest.fixture
def tty() -> Iterator[str]:
    with pseudo_terminal() as path:
        yield path


def checked(path: Path, capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str]:
    """``check-config --no-auth FILE`` in this process: its exit code and output, within the
    CPU and memory budget."""
    tracemalloc.start()
    started = time.process_time()
    try:
        code = main(["check-config", "--no-auth", *argv, str(path)])
        spent = time.process_time() - started
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    out = capsys.readouterr().out
    assert spent < CPU_BUDGET, f"{spent:.2f} s of CPU for one check"
    assert peak < MEMORY_BUDGET, f"{peak / 2**20:.0f} MiB for one check"
    return code, out


# ------------------------------------------------------------------ numbers that are not numbers


@pytest.mark.parametrize(
    ("key", "value", "where"),
    [
        ("soft_max", "nan", "loops[0].controllers[0].axes[0].soft_max"),
        ("soft_min", "-inf", "loops[0].controllers[0].axes[0].soft_min"),
        ("units_per_pulse", "inf", "loops[0].controllers[0].axes[0].units_per_pulse"),
        ("units_per_pulse", "+nan", "loops[0].controllers[0].axes[0].units_per_pulse"),
    ],
)
def test_a_float_that_is_not_finite_is_refused_naming_the_key(
    tmp_path: Path, tty: str, capsys: pytest.CaptureFixture[str], key: str, value: str, where: str
) -> None:
    # Before: soft_max = nan compared false with every target (the limit silently off), and
    # units_per_pulse = inf made every target in user units 0.
    path = tmp_path / "cell.toml"
    path.write_text(LOOP.format(name="main", port=tty) + AXIS.format(key=key, value=value))
    code, out = checked(path, capsys)
    assert code == 1, out
    found = problems_of(out)
    assert list(found) == [where], out
    assert "finite number" in found[where] and "NaN and ±inf are refused" in found[where]


@pytest.mark.parametrize(
    ("section", "where"),
    [
        ("[loops.timeouts]\nturnaround = nan", "loops[0].timeouts.turnaround"),
        ("[loops.poll]\nidle_period = inf", "loops[0].poll.idle_period"),
    ],
)
def test_every_section_refuses_a_float_that_is_not_finite(
    tmp_path: Path, tty: str, capsys: pytest.CaptureFixture[str], section: str, where: str
) -> None:
    path = tmp_path / "cell.toml"
    path.write_text(LOOP.format(name="main", port=tty) + section + "\n")
    code, out = checked(path, capsys)
    assert code == 1, out
    found = problems_of(out)
    assert list(found) == [where], out
    # Said as what it is (before: "greater than or equal to 0" for a NaN turnaround)
    assert "finite number (NaN and ±inf are refused" in found[where], out


def test_soft_limits_in_order_and_finite(
    tmp_path: Path, tty: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "cell.toml"
    path.write_text(
        LOOP.format(name="main", port=tty) + AXIS.format(key="soft_min", value="5.0")
        + "soft_max = 5.0\n"
    )  # fmt: skip
    code, out = checked(path, capsys)
    assert code == 1
    assert "soft_min 5.0 must be below soft_max 5.0" in out, out


def test_the_watched_spacing_of_the_idle_reads_is_never_closer_than_their_period(
    tmp_path: Path, tty: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "cell.toml"
    section = "[loops.poll]\nidle_period = 2.0\nwatched_idle_period = 1.0\n"
    path.write_text(LOOP.format(name="main", port=tty) + section)
    code, out = checked(path, capsys)
    assert code == 1, out
    found = problems_of(out)
    assert list(found) == ["loops[0].poll"], out
    assert "watched_idle_period 1.0: at least idle_period (2.0)" in found["loops[0].poll"], out


# ------------------------------------------------------------------ one loop a line


def _link(tmp_path: Path, tty: str) -> str:
    link = tmp_path / "by-id-adapter"
    link.symlink_to(tty)
    return str(link)


@pytest.mark.parametrize(
    ("first", "second"),
    [
        (lambda tmp, tty: tty, lambda tmp, tty: tty),
        (lambda tmp, tty: tty, _link),  # a by-id link and the device it names
        (lambda tmp, tty: "socket://moxa.local:4001", lambda tmp, tty: "socket://MOXA.local.:4001"),
        (lambda tmp, tty: "socket://10.0.0.7:4001", lambda tmp, tty: "rfc2217://10.0.0.7:4001"),
        (lambda tmp, tty: "socket://[::1]:4001", lambda tmp, tty: "socket://[0:0::1]:4001"),
    ],
)
def test_two_loops_on_one_line_are_refused(
    tmp_path: Path,
    tty: str,
    capsys: pytest.CaptureFixture[str],
    first: Callable[[Path, str], str],
    second: Callable[[Path, str], str],
) -> None:
    # Before: accepted, exit 0; two schedulers would write to one loop at once.
    path = tmp_path / "cell.toml"
    path.write_text(
        LOOP.format(name="a", port=first(tmp_path, tty))
        + LOOP.format(name="b", port=second(tmp_path, tty))
    )
    code, out = checked(path, capsys)
    assert code == 1, out
    found = problems_of(out)
    assert list(found) == ["loops[1].port"], out
    assert "is already the port of loops[0]: one loop a line" in found["loops[1].port"]


def test_two_ports_of_one_device_server_are_two_lines(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "cell.toml"
    path.write_text(
        LOOP.format(name="a", port="socket://moxa.local:4001")
        + LOOP.format(name="b", port="socket://moxa.local:4002")
    )
    code, out = checked(path, capsys)
    assert code == 0, out


# ------------------------------------------------------------------ files that are no configuration


def _write(content: bytes) -> Callable[[Path], None]:
    return lambda path: path.write_bytes(content)


HOSTILE: list[tuple[str, Callable[[Path], None], str]] = [
    (
        "arrays-900-deep",
        _write(b"x = " + b"[" * 900 + b"]" * 900 + b"\n"),
        "line 1, column 37: nested more than 32 levels deep",
    ),
    (
        "inline-tables-900-deep",
        _write(b"x = " + b"{a = " * 900 + b"1" + b"}" * 900 + b"\n"),
        "nested more than 32 levels deep",
    ),
    (
        "invalid-utf-8",
        _write(b'[[loops]]\nname = "caf\xe9"\n'),
        "not UTF-8: invalid byte 0xe9 at line 2, column 12 (offset 21)",
    ),
    (
        "binary",
        _write(b"\x1f\x8b\x08\x00" + bytes(range(256)) * 4),
        "a binary file (a NUL byte at offset 3), not TOML text",
    ),
    (
        "dotted-key-200-KB",
        _write(b"a" + b".a" * 100_000 + b" = 1\n"),
        "line 1, column 64: a dotted key of more than 32 parts",
    ),
    (
        "unknown-keys-10-MB",
        _write(b"".join(b"k%d = %d\n" % (i, i) for i in range(800_000))),
        "larger than 1048576 bytes: not a configuration",
    ),
    ("a-named-pipe", lambda path: os.mkfifo(path), "not a regular file"),
]


@pytest.mark.parametrize(("make", "words"), [h[1:] for h in HOSTILE], ids=[h[0] for h in HOSTILE])
def test_a_file_that_is_no_configuration_is_named_as_such(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], make: Callable[[Path], None], words: str
) -> None:
    # Before: tracebacks (RecursionError, UnicodeDecodeError), 24 GB for the dotted key, a
    # named pipe waited on for ever.
    path = tmp_path / "cell.toml"
    make(path)
    code, out = checked(path, capsys)
    assert code == 1, out
    assert out.splitlines()[0] == f"{path}: 1 problem(s)", out
    problem = problems_of(out)["(file)"]
    assert words in problem, out


def test_serve_refuses_a_hostile_file_as_quickly(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "cell.toml"
    path.write_bytes(b"a" + b".a" * 100_000 + b" = 1\n")
    started = time.process_time()
    assert main(["serve", "--config", str(path), "--no-auth"]) == 2
    assert time.process_time() - started < CPU_BUDGET
    assert "a dotted key of more than 32 parts" in capsys.readouterr().err


def test_many_mistakes_list_fifty_and_count_the_rest(
    tmp_path: Path, tty: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # Before: 873,813 problems and 53 MB of output for 10 MB of unknown keys. Under the size
    # bound, 2,000 of them are still one mistake to read about.
    keys = "".join(f"k{i} = {i}\n" for i in range(2_000))
    path = tmp_path / "cell.toml"
    path.write_text(keys + LOOP.format(name="main", port=tty))
    code, out = checked(path, capsys)
    assert code == 1
    lines = out.splitlines()
    assert lines[0] == f"{path}: 2000 problem(s)"
    assert lines[1:51] == [f"  k{i}: Extra inputs are not permitted" for i in range(50)]
    assert lines[51:] == ["  ... and 1950 more problem(s)"]


# ------------------------------------------------------------------ the same, as a process


def _bounded() -> None:
    """The child's limits: 256 MiB of address space, 20 s of CPU (the busy machine's share of a
    few seconds' work); the unbounded parser needed 24 GB."""
    resource.setrlimit(resource.RLIMIT_AS, (256 << 20, 256 << 20))
    resource.setrlimit(resource.RLIMIT_CPU, (20, 20))


@pytest.mark.parametrize("name", ["dotted-key-200-KB", "unknown-keys-10-MB"])
def test_check_config_as_a_process_stays_within_bounds(tmp_path: Path, name: str) -> None:
    make, words = next(h[1:] for h in HOSTILE if h[0] == name)
    path = tmp_path / "cell.toml"
    make(path)
    done = subprocess.run(
        [str(GATEWAY), "check-config", str(path)],
        preexec_fn=_bounded,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 1, done.stderr  # not killed by a limit, not a traceback
    assert words in done.stdout
    assert done.stderr == ""


@pytest.mark.parametrize(
    ("text", "where", "words"),
    [
        ('audit_log = "a\\u0000b"\n', "audit_log", "holds a NUL character"),
        (
            '[[loops]]\nname = "m"\nport = "/dev/x\\u0000y"\n[[loops.controllers]]\nbody = "1"\n',
            "loops[0].port",
            "control characters are not allowed",
        ),
        ('loops = [1, "a", {port = 5}]\n', "loops[2].port", "Input should be a valid string"),
        ("loops = {a = 1}\n", "loops", "Input should be a valid list"),
    ],
)
def test_odd_values_are_named_never_a_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, where: str, words: str
) -> None:
    # Before: ValueError("embedded null byte") from os.stat, a traceback.
    path = tmp_path / "cell.toml"
    path.write_text(text)
    code, out = checked(path, capsys)
    assert code == 1, out
    assert words in problems_of(out)[where], out


def test_serve_lists_fifty_problems_and_counts_the_rest(
    tmp_path: Path, tty: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "cell.toml"
    path.write_text("".join(f"k{i} = {i}\n" for i in range(500)) + LOOP.format(name="m", port=tty))
    assert main(["serve", "--config", str(path), "--no-auth"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0] == f"rc233-gateway serve: {path}: 500 problem(s)"
    assert err[1:] == [
        *(f"  k{i}: Extra inputs are not permitted" for i in range(50)),
        "  ... and 450 more problem(s)",
    ]
