"""The health and metrics routes at the root, open without a token (a probe or a scraper
has none).

``/healthz``: the process answers (200). ``/readyz``: 200 when every loop is up and the audit
log's file takes its lines, else a 503 problem naming the loops that are down (``loops_down``)
and the audit log's failure. The audit log's writer tries a failing file again by itself
(``[audit] retry_seconds``), so readiness comes back when the file takes writes, without
waiting for a request that acts. ``/metrics``: Prometheus text (the audit log's series too).
``install_health_and_metrics(app, gateway)`` sets them up with the HTTP metrics middleware.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, FastAPI, Request
from fastapi.responses import Response
from pydantic import BaseModel

from gateway.api.app_services import held_services
from gateway.api.audit_log import audit_exposition
from gateway.api.metrics.collector import (
    CONTENT_TYPE,
    HttpMetricsMiddleware,
    Metrics,
    MetricsSource,
    WsStats,
)
from gateway.api.metrics.processes import process_exposition
from gateway.api.problems import PROBLEM_MEDIA_TYPE, Problem, problem_response, problem_type
from gateway.service.runtime.bus_types import LinkState

__all__ = ["Health", "Readiness", "install_health_and_metrics", "router"]

router = APIRouter(tags=["operations"])


class Health(BaseModel):
    """The process is alive."""

    status: str = "ok"


class Readiness(BaseModel):
    """Every loop is up: each loop's line state."""

    status: str = "ready"
    loops: dict[str, str]


def _metrics(request: Request) -> Metrics:
    metrics = request.app.state.metrics
    assert isinstance(metrics, Metrics), "install_health_and_metrics(app, gateway) was not called"
    return metrics


@router.get("/healthz", response_model=Health)
async def healthz() -> Health:
    """200 while the process answers (no line traffic)."""
    return Health()


_NOT_READY: dict[int | str, dict[str, Any]] = {
    503: {
        "model": Problem,
        "description": "A loop is down (``loops_down`` names them)",
        "content": {PROBLEM_MEDIA_TYPE: {"schema": {"$ref": "#/components/schemas/Problem"}}},
    }
}


@router.get("/readyz", response_model=Readiness, responses=_NOT_READY)
async def readyz(request: Request) -> Any:
    """200 when every loop is up and the audit file takes writes; else 503 naming why."""
    runtime = _metrics(request).runtime
    if runtime is None:
        states: dict[str, str] = {}
        down = ["(no gateway)"]
    else:
        states = {name: str(loop.state) for name, loop in sorted(runtime.schedulers.items())}
        down = [
            name
            for name, loop in sorted(runtime.schedulers.items())
            if loop.state is not LinkState.UP
        ]
    services = held_services(request)
    audit_error = None if services is None else services.audit.last_error
    if runtime is not None and runtime.ready() and not down and audit_error is None:
        return Readiness(loops=states)
    causes = []
    if runtime is not None:
        for name in down:
            cause = getattr(runtime.schedulers[name], "cause", "")
            causes.append(f"{name} ({states[name]}{': ' + cause if cause else ''})")
    detail = "not ready; loops down: " + (", ".join(causes) or ", ".join(down) or "none")
    if audit_error:
        detail += f"; the audit log cannot be written ({audit_error})"
    problem = Problem(
        type=problem_type("not-ready"),
        title="Not ready",
        status=503,
        detail=detail,
        loops_down=down,
    )
    return problem_response(problem, request, {"Retry-After": "1"})


@router.get(
    "/metrics",
    response_class=Response,
    responses={200: {"content": {CONTENT_TYPE: {"schema": {"type": "string"}}}}},
)
async def metrics(request: Request) -> Response:
    """Prometheus text exposition format 0.0.4."""
    text = _metrics(request).render()
    services = held_services(request)
    if services is not None:
        text += audit_exposition(services.audit)
    text += process_exposition(services)
    return Response(text, media_type=CONTENT_TYPE)


@router.head("/metrics", include_in_schema=False)
async def metrics_head(request: Request) -> Response:
    """What ``GET /metrics`` would answer, without the body (probes, curl -I)."""
    body = _metrics(request).render().encode()
    headers = {"Content-Length": str(len(body))}
    return Response(media_type=CONTENT_TYPE, headers=headers)


def install_health_and_metrics(
    app: FastAPI, runtime: MetricsSource | None, *, ws: WsStats | None = None
) -> Metrics:
    """Serve ``/healthz``, ``/readyz`` and ``/metrics`` and count HTTP requests; the
    ``Metrics`` (its ``ws`` is the ``WsStats`` for the WebSocket hub). Call it last of the
    ``install_*`` functions so its middleware is the outermost and times everything."""
    metrics = Metrics(runtime, ws=ws)
    app.state.metrics = metrics
    app.add_middleware(HttpMetricsMiddleware, metrics=metrics)
    app.include_router(router)
    return metrics
