"""The composition root: the services of a runtime, built once, for every face.

``compose(runtime)`` builds the audit record (``audit_log``, ``[audit]``), the control leases,
the operations book, the axis and controller services, stop-all, the baud changer and the
WebSocket feed, and subscribes the audit entries no request makes (an operation resolved by
reading the axis back, a jog the last process left running and this one stopped, a key
switch's control change, an origin lost by a reset). ``rc233-gateway serve`` hands the
``Services`` to the REST/WebSocket app (``gateway.api.app.create_app``), the MQTT edge node
and the OPC UA face; tests do the same (``create_app(compose(runtime), auth=...)``).

It sits above the faces (the layers in pyproject.toml): the entries it subscribes are the
audit log's, whose paths are the REST API's names of the things they concern.
"""

from __future__ import annotations

from gateway.api.app import API_PREFIX
from gateway.api.audit import control_entry, origin_entry, resolution_entry
from gateway.service.audit import AuditRecord, FsyncPolicy, RotationPolicy
from gateway.service.axes import AxisService
from gateway.service.baud import BaudChanger
from gateway.service.config import GatewayConfig
from gateway.service.control import ControlChange
from gateway.service.controllers import ControllerService
from gateway.service.events import ServiceEvent
from gateway.service.feed import Feed
from gateway.service.leases import Leases
from gateway.service.operations import Operations
from gateway.service.runtime.runtime import Runtime
from gateway.service.services import Services
from gateway.service.stops import StopAll

__all__ = ["audit_of", "compose"]


def audit_of(config: GatewayConfig) -> AuditRecord:
    """The audit log of ``config`` (``audit_log``, ``[audit]``)."""
    settings = config.audit
    return AuditRecord(
        config.audit_log,
        rotation=RotationPolicy(max_bytes=settings.max_bytes, keep=settings.keep),
        fsync=FsyncPolicy(settings.fsync),
        retry_interval=settings.retry_seconds,
    )


def compose(runtime: Runtime) -> Services:
    """The services of ``runtime``, not started yet (``Services.start``)."""
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
    return Services(
        runtime=runtime,
        audit=audit,
        leases=leases,
        operations=operations,
        axes=AxisService(runtime, operations, leases),
        controllers=ControllerService(runtime, leases, operations),
        stops=StopAll(runtime, operations),
        baud=BaudChanger(runtime),
        feed=feed,
    )
