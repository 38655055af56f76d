"""The README as it stands: its first calls and its control-surface example run as written,
what it says ``make run`` is matches the Makefile, and it says nothing twice.

Each line of the "First calls" block runs in a shell as written, against `serve --simulate`
on a free port (the only change: the port, and curl told to print the status code), at a
scaled time so that the first home takes about two seconds instead of sixty; the home's own
duration, scaled back, is held against the figure the README gives and the timeout it sends.
"""

from __future__ import annotations

import asyncio
import json
import re
import shutil
import sys
from pathlib import Path

from tests.support.serve_process import TIME_SCALE, free_port, serve
from tests.support.sim_process import sim_on_pty

ROOT = Path(__file__).parents[1]
README = ROOT / "README.md"
MAKEFILE = ROOT / "Makefile"


def sh_blocks(text: str) -> list[str]:
    """The README's ``sh`` code blocks."""
    return re.findall(r"```sh\n(.*?)```\n", text, flags=re.S)


def prose(text: str) -> str:
    """The README without its code blocks."""
    return re.sub(r"```.*?```\n", "", text, flags=re.S)


def first_calls() -> list[str]:
    """The commands of the README's "First calls" block, continuation lines joined."""
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## First calls") :]
    block = section[section.index("```sh\n") + 6 : section.index("```\n", 6)]
    commands = re.sub(r"\\\n\s*", "", block).splitlines()
    return [c.strip() for c in commands if c.strip()]


async def test_the_first_calls_work_pasted_in_order(tmp_path: Path) -> None:
    curl = shutil.which("curl")
    assert curl, "curl is not installed: `apt-get install curl` (`make test` does it)"
    commands = first_calls()
    assert [c.split()[0] for c in commands] == ["curl"] * 5
    async with serve(tmp_path) as server:
        answers = []
        for command in commands:
            command = command.replace("127.0.0.1:8233", f"127.0.0.1:{server.port}")
            command = command.replace("curl ", "curl -sS -w '\\n%{http_code}' ", 1)
            shell = await asyncio.create_subprocess_shell(
                command, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE
            )
            out, err = await asyncio.wait_for(shell.communicate(), 60)
            assert shell.returncode == 0, (command, err)
            body, status = out.decode().rsplit("\n", 1)
            assert status == "200", (command, status, body)
            answers.append(json.loads(body))
    axes, home, move, axis, _stop = answers
    assert [a["name"] for a in axes][:2] == ["x", "y"]
    assert (home["kind"], home["state"]) == ("home", "done")
    # the home's real duration (at time scale 1) is the README's figure, well inside its timeout
    real = (home["ended"] - home["created"]) * TIME_SCALE
    home_line = next(c for c in commands if "/home?" in c)
    said = float(re.search(r"about (\d+) s", home_line).group(1))  # its comment
    timeout = float(re.search(r"timeout=(\d+)", home_line).group(1))
    assert abs(real - said) <= 0.2 * said, (real, said)
    assert real <= timeout / 1.5, (real, timeout)
    assert (move["kind"], move["state"]) == ("move", "done")
    assert (axis["position"], axis["position_user"]) == (1250, 12.5)


def test_make_run_is_said_once_and_is_what_the_makefile_runs() -> None:
    recipe = MAKEFILE.read_text().split("\nrun:", 1)[1].split("\n\n", 1)[0]
    command = re.search(r"rc233-gateway (serve [^\n]*)", recipe)
    assert command, recipe
    assert "--simulate --no-auth" in command.group(1), command.group(1)
    text = prose(README.read_text(encoding="utf-8"))
    claims = re.findall(r"`make run` is\s+`rc233-gateway ([^`]*)`", text)
    assert claims == ["serve --simulate --no-auth"], claims


def test_no_paragraph_row_or_sentence_is_said_twice() -> None:
    text = prose(README.read_text(encoding="utf-8"))
    paragraphs = [" ".join(p.split()) for p in text.split("\n\n") if p.strip()]
    assert len(paragraphs) == len(set(paragraphs)), "a paragraph appears twice"
    # no table names the same thing in two rows
    firsts = [p.split("|")[1].strip() for p in text.splitlines() if p.startswith("| ")]
    assert len(firsts) == len(set(firsts)), sorted(f for f in firsts if firsts.count(f) > 1)
    # a sentence (or a fragment of one) of 60 characters or more says it once
    seen: dict[str, int] = {}
    flat = " ".join(text.split())
    for i in range(0, len(flat) - 60):
        seen[flat[i : i + 60]] = seen.get(flat[i : i + 60], 0) + 1
    twice = sorted({k for k, n in seen.items() if n > 1})
    assert twice == [], twice[:3]


async def test_the_control_surface_example_runs_with_the_projects_own_python(
    tmp_path: Path,
) -> None:
    block = next(b for b in sh_blocks(README.read_text(encoding="utf-8")) if '"op": "ems"' in b)
    port = free_port()
    command = block.replace('127.0.0.1", 5234', f'127.0.0.1", {port}').replace(
        ".venv/bin/python", str(Path(sys.executable))
    )
    assert command.count(str(port)) == 1, block
    async with sim_on_pty(tmp_path, "--control", f"127.0.0.1:{port}"):
        shell = await asyncio.create_subprocess_shell(
            command, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE
        )
        out, err = await asyncio.wait_for(shell.communicate(), 30)
    assert shell.returncode == 0, err.decode()
    assert json.loads(out) == {"ok": True}, out
