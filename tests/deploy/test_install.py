"""`pip install` of the built wheel gives a working `rc233-gateway` with runtime dependencies only.

The test tool chain is the `test` extra: a fresh environment that installs the wheel must not
receive pytest, mypy or schemathesis, and the command must still start (`--version`, and the
`openapi` document, which imports the whole API: FastAPI, pydantic, the routers).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib
import venv
from pathlib import Path

from gateway import __version__

ROOT = Path(__file__).parents[2]


def _run(*argv: str | Path, timeout: float = 120) -> str:
    done = subprocess.run(
        [str(a) for a in argv], capture_output=True, text=True, timeout=timeout, check=False
    )
    assert done.returncode == 0, f"{argv}:\n{done.stdout}\n{done.stderr}"
    return done.stdout


def test_the_wheel_installs_and_runs_with_runtime_dependencies_only(tmp_path: Path) -> None:
    wheels = tmp_path / "wheels"
    _run(sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", wheels, ROOT)
    (wheel,) = wheels.glob("rc233_gateway-*.whl")
    assert wheel.name.startswith(f"rc233_gateway-{__version__}-")
    # A bare environment; this interpreter's pip installs into it (no ensurepip: cheaper).
    env = tmp_path / "env"
    venv.create(env, with_pip=False)
    python = env / "bin" / "python"
    _run(sys.executable, "-m", "pip", "--python", python, "install", "--quiet", wheel)

    version = _run(env / "bin" / "rc233-gateway", "--version")
    assert version.strip() == f"rc233-gateway {__version__}"
    documents = tmp_path / "docs"
    _run(env / "bin" / "rc233-gateway", "openapi", "--out", documents)
    assert json.loads((documents / "openapi.json").read_text())["info"]["version"] == __version__

    installed = {
        line.split("==")[0].lower().replace("_", "-")
        for line in _run(sys.executable, "-m", "pip", "--python", python, "freeze").split()
    }
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    tool_chain = {r.split(">")[0].split("<")[0].split("[")[0].strip().lower()
                  for r in project["optional-dependencies"]["test"]}  # fmt: skip
    assert "pytest" in tool_chain and "mypy" in tool_chain
    leaked = installed & tool_chain
    assert not leaked, f"the test tool chain leaked into the runtime: {leaked}"
