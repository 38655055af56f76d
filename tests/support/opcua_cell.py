"""One ``rc233-gateway serve --simulate`` with an ``[opcua]`` section for the module's tests:
two loops' worth of names, an operator and a viewer token, soft limits, a key switch."""

from __future__ import annotations

import hashlib
from collections.abc import AsyncIterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest_asyncio

from tests.support.serve_process import Served, free_port, serve
from tests.support.ws_events import sim_control

OPERATOR = ("op", "operator-token-0123456789")
VIEWER = ("view", "viewer-token-0123456789")
WAIT = 10.0


def _token(name: str, role: str, token: str) -> str:
    digest = hashlib.sha256(token.encode()).hexdigest()
    return f'[[security.tokens]]\nname = "{name}"\nrole = "{role}"\nsha256 = "{digest}"\n'


def cell_config(workdir: Path, opc_port: int) -> str:
    """The cell: loop ``main``, controller ``lift`` (axis ``z`` in mm with soft limits) and
    ``press`` (a key switch on input bit 0)."""
    return f'''
state_dir = "{workdir / "state"}"
audit_log = "{workdir / "audit.jsonl"}"

[[loops]]
name = "main"
port = "/dev/null"
poll = {{ idle_period = 1.0 }}  # the key switch read each second: local control seen soon

[[loops.controllers]]
body = "1"
name = "lift"
[[loops.controllers.axes]]
motor = 1
name = "z"
unit = "mm"
units_per_pulse = 0.01
soft_min = -10
soft_max = 100

[[loops.controllers]]
body = "2"
name = "press"
local_input = {{ bit = 0, active = "on" }}
[[loops.controllers.axes]]
motor = 1
name = "ram"

{_token(OPERATOR[0], "operator", OPERATOR[1])}
{_token(VIEWER[0], "viewer", VIEWER[1])}

[opcua]
endpoint = "opc.tcp://127.0.0.1:{opc_port}"
security_policies = ["None", "Basic256Sha256_SignAndEncrypt", "Basic256Sha256_Sign",
                     "Aes256Sha256RsaPss_SignAndEncrypt", "Aes256Sha256RsaPss_Sign"]
'''


@dataclass
class Cell:
    """The running gateway: its OPC UA endpoint, directories and simulator control."""

    served: Served
    endpoint: str
    workdir: Path
    control_port: int

    @property
    def pki(self) -> Path:
        """The client's certificate folder."""
        return self.workdir / "client-pki"

    async def control(self, **request: Any) -> dict[str, Any]:
        """One request to the simulator's control surface."""
        # a trace of the whole run is longer than a stream's default line limit
        return await sim_control(self.control_port, limit=2**24, **request)


@pytest_asyncio.fixture(scope="module", loop_scope="module")
async def cell(tmp_path_factory: Any) -> AsyncIterator[Cell]:
    workdir: Path = tmp_path_factory.mktemp("opcua")
    opc_port, control_port = free_port(), free_port()
    config = workdir / "cell.toml"
    config.write_text(cell_config(workdir, opc_port))
    async with serve(
        workdir, "--simulate", "--config", str(config), "--time-scale", "25",
        "--control", f"127.0.0.1:{control_port}",
    ) as served:  # fmt: skip
        yield Cell(served, f"opc.tcp://127.0.0.1:{opc_port}", workdir, control_port)
