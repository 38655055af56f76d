"""The README's first calls work when pasted in order, with the real curl.

Each line of the "First calls" block runs in a shell as written, against `serve --simulate`
on a free port (the only change: the port, and curl told to print the status code), at a
scaled time so that homing takes a second instead of 25.
"""

from __future__ import annotations

import asyncio
import json
import re
import shutil
from pathlib import Path

from tests.serve_process import serve

README = Path(__file__).parents[1] / "README.md"


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
    assert (move["kind"], move["state"]) == ("move", "done")
    assert (axis["position"], axis["position_user"]) == (1250, 12.5)
