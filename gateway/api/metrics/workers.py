"""The line workers' series of ``/metrics``: each worker process up or not, and how many
times it died and was started again (``worker``: its loops joined by ``+``).

A gateway whose loops run in its own process (the test seam, ``serve --simulate``) has no
worker: the families are then written without samples.
"""

from __future__ import annotations

from gateway.api.metrics.exposition import Exposition
from gateway.service.runtime.runtime import Runtime

__all__ = ["render_workers"]


def render_workers(out: Exposition, runtime: object) -> None:
    """``rc233_worker_up`` and ``rc233_worker_restarts_total`` of every line worker."""
    workers = runtime.workers if isinstance(runtime, Runtime) else None
    supervisors = workers.supervisors if workers is not None else []
    out.family("rc233_worker_up", "gauge", "1 while the line worker process runs and is connected.")
    for supervisor in supervisors:
        out.sample("rc233_worker_up", {"worker": supervisor.name}, 1 if supervisor.up else 0)
    out.family(
        "rc233_worker_restarts_total", "counter", "Times the line worker died and was restarted."
    )
    for supervisor in supervisors:
        out.sample("rc233_worker_restarts_total", {"worker": supervisor.name}, supervisor.restarts)
