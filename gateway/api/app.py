"""The FastAPI application: routers, error handlers, security, audit, metrics, WebSocket.

``create_app(gateway, no_auth=...)`` wires the service objects onto ``app.state`` (the
routers read them from there) and mounts every router under ``/api/v1``; ``/healthz``,
``/readyz`` and ``/metrics`` stay at the root for probes and scrapers; the browser dashboard is
served at ``/`` and the API docs at ``/api/v1/docs`` from the package's own files
(``gateway.api.dashboard``). The app's lifespan starts the gateway's loops and, on shutdown,
stops accepting requests, lets each loop's transaction in flight finish (a move half-sent is
worse than one refused) and closes the ports.
"""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware

from gateway import __version__
from gateway.api.audit import (
    AuditLog,
    control_entry,
    install_audit,
    origin_entry,
    resolution_entry,
)
from gateway.api.auth_failures import AuthFailures
from gateway.api.dashboard import install_dashboard
from gateway.api.middleware.body_gate import BodyGate
from gateway.api.middleware.fresh_reads import FreshReadGate
from gateway.api.middleware.hardening import HardeningMiddleware
from gateway.api.middleware.idempotency import install_idempotency
from gateway.api.middleware.request_guard import RequestGuard
from gateway.api.openapi_docs import install_openapi_docs, operation_id
from gateway.api.problems import install_problem_handlers
from gateway.api.redaction import install_log_redaction
from gateway.api.routes import axes as routes_axes
from gateway.api.routes import baud as routes_baud
from gateway.api.routes import control as routes_control
from gateway.api.routes import controllers as routes_controllers
from gateway.api.routes import loops as routes_loops
from gateway.api.routes import operations as routes_operations
from gateway.api.routes import session as routes_session
from gateway.api.routes.axis_read_path import AxisReadPath
from gateway.api.routes.health import install_health_and_metrics
from gateway.api.security import AuthConfig, install_security
from gateway.api.ws import endpoint as ws
from gateway.service.audit import FsyncPolicy, RotationPolicy
from gateway.service.axes.service import AxisService
from gateway.service.baud import BaudChanger
from gateway.service.config import GatewayConfig
from gateway.service.control import ControlChange
from gateway.service.controllers.service import ControllerService
from gateway.service.events import ServiceEvent
from gateway.service.feed import Feed
from gateway.service.leases import Leases
from gateway.service.operations.book import Operations
from gateway.service.runtime.runtime import Runtime
from gateway.service.stops import StopAll

__all__ = ["API_PREFIX", "create_app"]

log = logging.getLogger("gateway.api")

API_PREFIX = "/api/v1"

DESCRIPTION = """\
REST and WebSocket access to RORZE RC-233 controllers on RS-232C loops.

* Reads (`GET`) answer from the gateway's state cache: no line traffic unless `?fresh=true`.
* Motion requests answer `202` with an operation (`GET /operations/{id}`), or wait for the end
  with `?wait=true&timeout=s`. An `Idempotency-Key` header makes a retried POST return the
  first result instead of acting again.
* Errors are `application/problem+json` (RFC 9457) naming the field and the rule. Bodies are
  JSON (`Content-Type: application/json`, else 415) of at most 256 KiB (else 413, refused
  before it is read); numbers are finite JSON numbers and booleans JSON booleans.
* Every answer carries `X-Content-Type-Options: nosniff`, `Cache-Control: no-store` and
  frame protection. `/metrics` and these docs are open unless `security.open_metrics` /
  `security.open_docs` is false.
* Roles: viewer (read, subscribe), operator (motion, settings, leases), admin (raw, EEPROM,
  programs, mode, framing, line trace). Bearer tokens.
* The WebSocket `/api/v1/ws` publishes axis, controller and loop state and events; its
  message schema is `openapi/websocket.json`.
"""


def audit_of(config: GatewayConfig) -> AuditLog:
    """The audit log of ``config`` (``audit_log``, ``[audit]``)."""
    settings = config.audit
    return AuditLog(
        config.audit_log,
        rotation=RotationPolicy(max_bytes=settings.max_bytes, keep=settings.keep),
        fsync=FsyncPolicy(settings.fsync),
        retry_interval=settings.retry_seconds,
    )


def create_app(runtime: Runtime, *, auth: AuthConfig) -> FastAPI:
    """The application serving ``gateway`` with ``auth`` (tokens, or no-auth mode)."""
    audit = audit_of(runtime.config)
    leases = Leases()
    operations = Operations(runtime)
    operations.on_resolved(lambda op: audit.record(resolution_entry(op, API_PREFIX)))
    # A jog the last process left running, stopped by this one at start: no request made it.
    operations.on_restart_stop(lambda stop: audit.record(stop.audit_entry(API_PREFIX)))

    # An admin's change of the control state is its request's entry; a key switch's has none.
    def audit_key_switch(change: ControlChange) -> None:
        if change.source == "key_switch":
            audit.record(control_entry(change, API_PREFIX))

    runtime.control.changes.subscribe(audit_key_switch)

    def audit_origin(event: ServiceEvent) -> None:  # a reset seen on the line: no request
        entry = origin_entry(event, API_PREFIX)
        if entry is not None:
            audit.record(entry)

    runtime.events.subscribe(audit_origin)
    feed = Feed(
        runtime.topology,
        runtime.state,
        runtime.events,
        runtime.config.ws,
        control=runtime.control,
        loop_baud=lambda name: runtime.scheduler(name).timing.baud,
        loop_adapter=lambda name: runtime.scheduler(name).transport.adapter,
    )

    install_log_redaction()  # no token in any log line, whoever prints it

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        audit.start()
        await operations.restore()  # before the loops: what the last process left unended
        await runtime.start()
        try:
            yield
        finally:
            feed.close()
            operations.close()
            failures.close()
            await runtime.close()
            await audit.close()

    app = FastAPI(
        title="rc233-gateway",
        version=__version__,
        description=DESCRIPTION,
        lifespan=lifespan,
        openapi_url=f"{API_PREFIX}/openapi.json",
        # Swagger UI from vendored files (install_dashboard): the docs work with no internet.
        docs_url=None,
        redoc_url=None,
        generate_unique_id_function=operation_id,
    )
    app.state.runtime = runtime
    app.state.leases = leases
    app.state.operations = operations
    app.state.axes = AxisService(runtime, operations, leases)
    app.state.controllers = ControllerService(runtime, leases, operations)
    app.state.stops = StopAll(runtime, operations)
    app.state.baud = BaudChanger(runtime)
    modules = (
        routes_axes,
        routes_operations,
        routes_controllers,
        routes_loops,
        routes_control,
        routes_baud,
        routes_session,
        ws,
    )
    for module in modules:
        app.include_router(module.router, prefix=API_PREFIX)
    ws.install_ws(app, feed)
    install_dashboard(app, API_PREFIX)
    # Middleware added later wraps what was added before: the cached read innermost, then
    # the problem handlers, security, idempotency, the body gate (inside the audit, which
    # records what it refuses), audit, the host and origin guard, metrics, and CORS
    # outermost so that error responses carry the CORS headers too.
    # Innermost: the plain cached read of an axis, answered without routing (every layer
    # outside still applies to it); anything else it hands on.
    app.add_middleware(AxisReadPath, runtime=runtime, prefix=API_PREFIX)
    # Around it: a caller's fresh reads beyond a few at a time become cached reads.
    app.add_middleware(FreshReadGate, prefix=API_PREFIX)
    install_problem_handlers(app)
    failures = AuthFailures(audit.record)
    install_security(app, auth, failures)
    install_idempotency(app, runtime.store)
    app.add_middleware(BodyGate)
    install_audit(app, audit)
    # Outside the audit (a request to another host or from another site never reached the
    # API), inside the metrics and the access line (which count it).
    app.add_middleware(
        RequestGuard,
        allowed_hosts=runtime.config.security.allowed_hosts,
        cors_origins=runtime.config.security.cors_origins,
    )
    install_health_and_metrics(app, runtime)
    install_openapi_docs(app)
    security = runtime.config.security
    closed = ([] if security.open_metrics else ["/metrics"]) + (
        []
        if security.open_docs
        else [app.openapi_url or "", f"{API_PREFIX}/docs", f"{API_PREFIX}/redoc"]
    )
    app.add_middleware(HardeningMiddleware, closed=closed)
    origins = list(runtime.config.security.cors_origins)
    if origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=origins,
            allow_methods=["GET", "POST", "PUT", "DELETE"],
            allow_headers=["Authorization", "Content-Type", "Idempotency-Key"],
            expose_headers=["Location", "Retry-After", "Idempotent-Replayed"],
        )
    return app
