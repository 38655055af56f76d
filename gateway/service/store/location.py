"""Where the state directory is when the configuration has no ``state_dir``.

* ``serve`` on real lines: ``$STATE_DIRECTORY`` (what systemd's ``StateDirectory=`` gives the
  unit, ``/var/lib/rc233-gateway``), else ``$XDG_STATE_HOME/rc233-gateway``
  (``~/.local/state/rc233-gateway``): the record of a cell outlives its process by default.
* ``serve --simulate``: a new temporary directory per process, removed at exit. A simulated
  loop starts again from nothing each time (its axes at 0), so operations recorded against a
  previous one would be judged against a machine that no longer exists. Give ``state_dir`` to
  keep them (e.g. to try a restart).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

__all__ = ["APP_DIR", "default_state_dir"]

APP_DIR = "rc233-gateway"


def default_state_dir(environ: Mapping[str, str] = os.environ) -> Path:
    """The state directory of a gateway on real lines whose configuration names none."""
    systemd = environ.get("STATE_DIRECTORY")
    if systemd:
        return Path(systemd.split(":")[0])
    base = environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(base) / APP_DIR
