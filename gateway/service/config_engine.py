"""The line engine's section (``[engine]``): which loops share a line worker process.

``workers`` groups the loops into processes, e.g. ``workers = [["a", "b"], ["c"]]``: every
configured loop in exactly one group, no unknown name. Without it, each loop has a worker
of its own on a host with more than one core, and one worker runs every loop on a host with
one (two processes on one core only take turns). ``worker_groups`` decides.

``restart_backoff`` is how long a worker that died stays down before it is started again:
real seconds, one a death in a row, the last repeated (a worker that lived a minute starts
the list over).
"""

from __future__ import annotations

import os
from collections.abc import Sequence

from pydantic import Field, PositiveFloat

from gateway.service.config_base import Name, Strict

__all__ = ["EngineSettings", "check_groups", "worker_groups"]


class EngineSettings(Strict):
    """How the loops are spread over line worker processes."""

    #: the loops of each worker process; None: the default of ``worker_groups``
    workers: list[list[Name]] | None = Field(None, min_length=1)
    #: real seconds before each restart of a worker that died, the last repeated
    restart_backoff: list[PositiveFloat] = Field(
        [0.5, 1.0, 2.0, 4.0, 8.0, 15.0], min_length=1, max_length=16
    )


def check_groups(groups: Sequence[Sequence[str]], loops: Sequence[str]) -> None:
    """Every loop in exactly one group, and no other name: a ``ValueError`` naming the key
    and the rule otherwise."""
    known = set(loops)
    seen: dict[str, str] = {}
    for i, group in enumerate(groups):
        if not group:
            raise ValueError(f"engine.workers[{i}]: a worker runs at least one loop")
        for j, loop in enumerate(group):
            where = f"engine.workers[{i}][{j}]"
            if loop not in known:
                raise ValueError(f"{where}: {loop!r} is not a loop of this file (loops[].name)")
            if loop in seen:
                raise ValueError(f"{where}: loop {loop!r} is already in {seen[loop]}")
            seen[loop] = where
    missing = [loop for loop in loops if loop not in seen]
    if missing:
        raise ValueError(
            f"engine.workers: the loops {missing} are in no group (each loop in exactly one)"
        )


def worker_groups(
    settings: EngineSettings, loops: Sequence[str], cores: int | None = None
) -> list[list[str]]:
    """The loops of each worker process: the configured groups, else one worker a loop when
    the host has more than one core (``cores``: ``os.cpu_count()``), else one for all."""
    if settings.workers is not None:
        return [list(group) for group in settings.workers]
    cores = os.cpu_count() if cores is None else cores
    if (cores or 1) > 1:
        return [[loop] for loop in loops]
    return [list(loops)]
