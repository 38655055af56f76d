"""``rc233-gateway sim --pty`` as a separate process, the way a user runs it.

For the tests that reach the simulator through a real serial device: a customer's blocking
pyserial program (tests/sim) or the gateway's own serial path from a configuration file
(tests/api).
"""

from __future__ import annotations

import asyncio
import os
import re
import signal
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

GATEWAY = Path(sys.executable).parent / "rc233-gateway"


@asynccontextmanager
async def sim_on_pty(tmp_path: Path, *options: str) -> AsyncIterator[str]:
    """Start ``rc233-gateway sim --pty`` with ``options`` (EEPROM files under ``tmp_path``)
    and give its device path; after the block SIGTERM must end it with exit code 0."""
    env = {**os.environ, "XDG_DATA_HOME": str(tmp_path)}
    sim = await asyncio.create_subprocess_exec(
        str(GATEWAY), "sim", "--pty", "--eeprom-dir", str(tmp_path), *options,
        stdout=asyncio.subprocess.PIPE, env=env,
    )  # fmt: skip
    assert sim.stdout is not None
    try:
        line = (await asyncio.wait_for(sim.stdout.readline(), 20)).decode()
        found = re.search(r"listening on (\S+)", line)
        assert found, line
        yield found.group(1)
    finally:
        sim.send_signal(signal.SIGTERM)
        assert await asyncio.wait_for(sim.wait(), 20) == 0


async def run_script(script: Path, *argv: str, timeout: float = 50) -> bytes:
    """Run a Python program (a customer's blocking pyserial script) to its end; its output.

    A non-zero exit fails the test with the program's stderr."""
    process = await asyncio.create_subprocess_exec(
        sys.executable, str(script), *argv,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
    )  # fmt: skip
    out, err = await asyncio.wait_for(process.communicate(), timeout)
    assert process.returncode == 0, err.decode()
    return out
