"""node-opcua's client (tools/opcua-client), an OPC UA stack independent of the server's,
run on a scenario: one session, its steps in order, every result as JSON."""

from __future__ import annotations

import asyncio
import json
import shutil
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
CLIENT_DIR = ROOT / "tools" / "opcua-client"
INSTALL = (
    f"the OPC UA test client is not installed: run `make unit` or "
    f"`cd {CLIENT_DIR.relative_to(ROOT)} && npm ci --ignore-scripts` (node and npm: "
    "`apt-get install -y nodejs npm`)"
)
#: Real seconds a whole scenario may take on a busy machine.
SCENARIO_TIMEOUT = 90.0


def session(endpoint: str, pki: Path, steps: list[dict[str, Any]], *,
            user: str | None = None, password: str | None = None,
            policy: str = "None", mode: str = "None") -> dict[str, Any]:  # fmt: skip
    """One session's scenario: its login, security and steps."""
    return {"endpoint": endpoint, "pki": str(pki), "policy": policy, "mode": mode,
            "user": user, "password": password, "steps": steps}  # fmt: skip


async def run_client(endpoint: str, pki: Path, steps: list[dict[str, Any]],
                     **login: Any) -> dict[str, Any]:  # fmt: skip
    """Run ``steps`` in one session; ``{"connected", "results", "error"?}``."""
    answers = await run_sessions([session(endpoint, pki, steps, **login)])
    return answers[0]


async def run_sessions(sessions: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Run ``sessions`` one after the other in one client process; their answers."""
    node = shutil.which("node")
    assert node is not None and (CLIENT_DIR / "node_modules" / "node-opcua-client").is_dir(), (
        INSTALL
    )
    process = await asyncio.create_subprocess_exec(
        node, str(CLIENT_DIR / "client.mjs"), json.dumps(sessions),
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE, cwd=str(CLIENT_DIR),
    )  # fmt: skip
    out, err = await asyncio.wait_for(process.communicate(), SCENARIO_TIMEOUT)
    lines = out.decode().strip().splitlines()
    assert lines, f"the client said nothing; stderr: {err.decode()[-2000:]}"
    answers: list[dict[str, Any]] = json.loads(lines[-1])
    return answers


def node(ident: str) -> str:
    """The node id of the cell's namespace (index 2: the server's first own namespace)."""
    return f"ns=2;s={ident}"


def call(owner: str, method: str, *args: tuple[str, Any]) -> dict[str, Any]:
    """A step calling ``method`` of object ``owner``."""
    return {"op": "call", "object": node(owner), "method": node(f"{owner}/{method}"),
            "args": [list(a) for a in args]}  # fmt: skip
