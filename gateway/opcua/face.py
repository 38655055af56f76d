"""The OPC UA face: the server, its values fed by the state cache, its methods.

The serial loop never waits for OPC UA clients (as for MQTT): the state cache calls
``_on_change`` synchronously, which only marks the loop, controller or axis that moved and
wakes the writer; the writer computes their variables (``values``) and writes those whose
value, status or time moved, and asyncua sends the data changes to the monitored items. No
polling of the cache: a variable moves within the poll that read it.
"""

from __future__ import annotations

import asyncio
import logging
import time
from pathlib import Path
from typing import Any

from asyncua import Server, ua

from gateway.opcua.address_space import Nodes, build
from gateway.opcua.call_lanes import install_call_lanes, pending_calls
from gateway.opcua.certificate import ensure_certificate, server_files
from gateway.opcua.methods import Methods, StatusRefusal
from gateway.opcua.users import TokenUsers, install_caller_context
from gateway.opcua.values import Shown, Target, axis_values, controller_values, loop_values
from gateway.service.config import OpcUaSettings
from gateway.service.events import EventKind, ServiceEvent
from gateway.service.principal import Identify
from gateway.service.runtime.bus_types import Change
from gateway.service.services import Services

__all__ = ["OpcUaFace"]

log = logging.getLogger("gateway.opcua")

#: Owners (axes, controllers, loops) written between two yields to the event loop.
YIELD_EVERY = 16
#: Seconds the face waits at its stop for method calls still running.
CALLS_AT_STOP = 10.0

S = ua.VariantType.String
D = ua.VariantType.Double


def _arg(name: str, variant: ua.VariantType, text: str) -> ua.Argument:
    arg = ua.Argument()
    arg.Name = name
    arg.DataType = ua.NodeId(variant.value)
    arg.ValueRank = -1
    arg.Description = ua.LocalizedText(text)
    return arg


OPERATION = _arg("OperationId", S, "the operation started (GET /operations/{id})")
OUTCOME = _arg("Outcome", S, "done, not_done or unknown")
MODE = _arg("Mode", S, "decelerate (SS, default) or immediate (S)")


class OpcUaFace:
    """The server of ``[opcua]`` on ``gateway``; ``await start()``, ``await stop()``."""

    def __init__(
        self,
        services: Services,
        settings: OpcUaSettings,
        *,
        identify: Identify,
        state_dir: Path | None,
    ) -> None:
        """The face of ``services`` (the ones every face shares: the REST API's leases and
        operations bind its calls) whose users ``identify`` names."""
        self.runtime, self.settings = services.runtime, settings
        audit = services.audit
        self.methods = Methods(services.axes, services.stops, audit.record, audit.write_ahead)
        self.users = TokenUsers(identify, anonymous=settings.anonymous)
        self.state_dir = state_dir
        self.server = Server(user_manager=self.users)
        self.nodes: Nodes | None = None
        #: per axis, the target of its latest operation (pulses) and when it was set
        self.targets: dict[str, Target] = {}
        self._sent: dict[str, dict[str, Shown]] = {}
        self._dirty: set[str] = set()
        #: per loop, the time of its record's latest change (its values' source time)
        self._loop_changed: dict[str, float] = {}
        self._wake = asyncio.Event()
        self._writer: asyncio.Task[None] | None = None
        self._unlisten: list[Any] = []

    # ------------------------------------------------------------------ cache -> marks

    def _on_change(self, change: Change) -> None:
        """Synchronous, no I/O: mark what moved and wake the writer."""
        loop = change.loop
        if change.body is None:
            # (a mirrored loop record has no reading time: then when the face heard of it)
            self._loop_changed[loop] = change.time or time.monotonic()
            self._dirty.add(f"loop:{loop}")
            if "up" in change.values:
                for ctl in self.runtime.topology.controllers(loop):
                    self._dirty.add(ctl.id)
                    self._dirty.update(a.id for a in ctl.axes)
        else:
            ctl = self.runtime.topology.controller(f"{loop}.{change.body}")
            if change.motor is None:
                self._dirty.add(ctl.id)
                self._dirty.update(a.id for a in ctl.axes)  # online, stale: the axes too
            else:
                self._dirty.add(f"{ctl.id}.{change.motor}")
        self._wake.set()

    def _on_event(self, event: ServiceEvent) -> None:
        if event.kind is EventKind.OPERATION and event.topic.startswith("axis:"):
            axis = event.topic.partition(":")[2]
            target = event.data.get("target")
            pulses = target if isinstance(target, int) else None
            held = self.targets.get(axis)
            if held is None or held.pulses != pulses:  # its time: when it was set, not now
                self.targets[axis] = Target(pulses, event.time)
            self._dirty.add(axis)
            self._wake.set()
        elif event.kind is EventKind.CONTROL:
            self._dirty.update(c.id for c in self.runtime.topology.controllers())
            self._wake.set()

    def _shown(self, owner: str) -> dict[str, Shown]:
        topology = self.runtime.topology
        if owner.startswith("loop:"):
            return loop_values(self.runtime, owner[5:], self._loop_changed.get(owner[5:]))
        if owner.count(".") == 2:
            return axis_values(self.runtime, topology.axis(owner), self.targets.get(owner))
        ref = topology.controller(owner)
        shown = controller_values(self.runtime, ref, self._loop_changed.get(ref.loop))
        return shown

    async def _write(self, owner: str) -> None:
        assert self.nodes is not None
        shown = self._shown(owner)
        if owner in self.nodes.variables and "SoftwareRevision" in shown:
            plate = self.nodes.variables.get(f"{owner}/Identification", {})
            await self._write_table(
                f"{owner}/Identification", plate, {"SoftwareRevision": shown["SoftwareRevision"]}
            )
        await self._write_table(owner, self.nodes.variables.get(owner, {}), shown)

    async def _write_table(self, owner: str, table: Any, shown: dict[str, Shown]) -> None:
        sent = self._sent.setdefault(owner, {})
        for name, now in shown.items():
            var = table.get(name)
            if var is None or sent.get(name) == now:
                continue
            sent[name] = now
            await self.server.write_attribute_value(var.node, now.data_value(var.variant))

    async def _write_loop(self) -> None:
        while True:
            await self._wake.wait()
            self._wake.clear()
            written = 0
            while self._dirty:
                owner = self._dirty.pop()
                try:
                    await self._write(owner)
                except Exception:  # one bad value must not end the feed of all the others
                    log.exception("opcua: the values of %s not written", owner)
                written += 1
                if written % YIELD_EVERY == 0:  # asyncua's writes need not yield: let the
                    await asyncio.sleep(0)  # schedulers and the clients' requests in

    # ------------------------------------------------------------------ running

    async def start(self) -> None:
        """Build the address space, load or make the certificate, listen."""
        install_caller_context()
        install_call_lanes()
        # asyncua narrates every node it adds at INFO: thousands of lines for a cell
        logging.getLogger("asyncua").setLevel(logging.WARNING)
        settings = self.settings
        await self.server.init()
        self.server.set_endpoint(settings.endpoint)
        self.server.set_server_name("rc233-gateway")
        await self.server.set_application_uri(settings.application_uri)
        self.server.set_security_policy(
            [getattr(ua.SecurityPolicyType, _policy(p)) for p in settings.security_policies]
        )
        tokens: list[type] = [ua.UserNameIdentityToken]
        if settings.anonymous:
            tokens.append(ua.AnonymousIdentityToken)
        self.server.set_identity_tokens(tokens)
        if any(p != "None" for p in settings.security_policies):
            cert, key = settings.certificate, settings.private_key
            if cert is None or key is None:
                # serve's state store always has a directory; a test's in-memory one has none
                assert self.state_dir is not None, "a certificate to make needs a state_dir"
                cert, key = server_files(self.state_dir)
                if await ensure_certificate(cert, key, settings.application_uri):
                    log.info("opcua: made the server certificate %s", cert)
            await self.server.load_certificate(str(cert))
            await self.server.load_private_key(str(key))
        if settings.trusted_clients is not None:
            await self._trust(settings.trusted_clients)
        self.nodes = await build(self.server, self.runtime.topology)
        await self._add_methods(self.nodes)
        self._unlisten = [
            self.runtime.state.changes.subscribe(self._on_change),
            self.runtime.events.subscribe(self._on_event),
        ]
        # the loops' state as the face finds it: its source time is now (a change sets it)
        self._loop_changed = {loop.name: time.monotonic() for loop in self.runtime.topology.loops()}
        self._dirty.update(
            self.nodes.variables.keys()
            - {k for k in self.nodes.variables if k.endswith("/Identification")}
        )
        self._wake.set()
        self._writer = asyncio.create_task(self._write_loop())
        await self.server.start()
        log.info(
            "opcua: listening on %s (%s)", settings.endpoint, ", ".join(settings.security_policies)
        )

    async def _trust(self, folder: Any) -> None:
        from asyncua.crypto.truststore import TrustStore
        from asyncua.crypto.validator import CertificateValidator

        store = TrustStore([folder], [])
        await store.load()
        self.server.set_certificate_validator(CertificateValidator(trust_store=store))

    async def stop(self) -> None:
        """Stop listening to the cache and close the server."""
        for unlisten in self._unlisten:
            unlisten()
        if self._writer is not None:
            self._writer.cancel()
            await asyncio.gather(self._writer, return_exceptions=True)
        await self.server.stop()
        calls = pending_calls()
        if calls:  # a call that acts is let finish (its answer has nobody to go to)
            _, late = await asyncio.wait(calls, timeout=CALLS_AT_STOP)
            for task in late:
                task.cancel()

    async def _add_methods(self, nodes: Nodes) -> None:
        idx, m = nodes.index, self.methods
        for axis in nodes.axes.values():
            obj = nodes.objects[axis]
            await _method(
                obj,
                idx,
                axis,
                "MoveAbsolute",
                [_arg("Position", D, "the target"), _arg("Unit", S, "user (default) or pulse")],
                [OPERATION],
                lambda a, p, u: m.move(a, p, u, relative=False),
            )
            await _method(
                obj,
                idx,
                axis,
                "MoveRelative",
                [
                    _arg("Distance", D, "the distance, + is CW"),
                    _arg("Unit", S, "user (default) or pulse"),
                ],
                [OPERATION],
                lambda a, p, u: m.move(a, p, u, relative=True),
            )
            await _method(
                obj,
                idx,
                axis,
                "Home",
                [_arg("Method", S, "0 (default), 0A, 0H, 0R or 0Z (§10 0)")],
                [OPERATION],
                m.home,
            )
            await _method(obj, idx, axis, "Stop", [MODE], [OUTCOME], m.stop_axis)
            await _method(obj, idx, axis, "AcknowledgeErrors", [], [], m.acknowledge)
        for ctl in nodes.controllers.values():
            await _method(
                nodes.objects[ctl], idx, ctl, "Stop", [MODE], [OUTCOME], m.stop_controller
            )
        for loop in nodes.loops.values():
            await _method(
                nodes.objects[f"loop:{loop}"],
                idx,
                f"loop:{loop}",
                "Stop",
                [MODE],
                [OUTCOME],
                m.stop_loop,
            )


async def _method(
    obj: Any,
    idx: int,
    owner: str,
    name: str,
    inputs: list[ua.Argument],
    outputs: list[ua.Argument],
    act: Any,
) -> None:
    target = owner.removeprefix("loop:")
    out = outputs[0] if outputs else None

    async def handler(parent: ua.NodeId, *args: ua.Variant) -> list[ua.Variant] | ua.StatusCode:
        # A refusal is returned as the call's status code (asyncua answers an exception
        # raised here with Bad_UnexpectedError, which would hide why).
        values = [a.Value for a in args]
        if len(values) != len(inputs):
            return ua.StatusCode(ua.StatusCodes.BadArgumentsMissing)
        try:
            answer = await act(target, *values)
        except StatusRefusal as exc:
            return ua.StatusCode(exc.status)
        return [] if out is None else [ua.Variant(answer, S)]

    await obj.add_method(
        ua.NodeId(f"{owner}/{name}", idx), ua.QualifiedName(name, idx), handler, inputs, outputs
    )


def _policy(name: str) -> str:
    return "NoSecurity" if name == "None" else name
