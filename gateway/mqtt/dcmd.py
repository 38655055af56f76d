"""DCMD: stop and acknowledge over MQTT, when the configuration enables them (``commands``).

A host writes, in one DCMD to a controller's device, ``Command/Token`` (an API token, the
same the REST API takes) and any of ``Axis/<a>/Stop = true`` and ``Axis/<a>/Errors/Ack =
true``. The token must name an operator or an admin (as ``POST /axes/{id}/stop``); anything
else is refused whole. Every DCMD, refused ones too, is one entry in the audit log, with
``method`` ``DCMD`` and the topic as ``path``; the token itself is never recorded. A token is
needed even when the REST API runs without authentication (``--no-auth``, ``--simulate``):
that mode is for loopback, and a broker is not.

Stop is ``SS`` (decelerate): what a remote host should ask of a machine it does not see.
Nothing else is accepted over MQTT: moves, settings and programs stay on the REST API.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping
from typing import Any, Protocol

from gateway.errors import GatewayError
from gateway.mqtt.sparkplug import Value
from gateway.service.audit import WriteAhead
from gateway.service.operations.terms import StopMode
from gateway.service.principal import Identify, Principal
from gateway.service.roles import Role
from gateway.service.services import Services
from gateway.service.topology import ControllerRef

__all__ = ["CLIENT", "CommandResult", "DeviceCommands", "StopAxes"]

log = logging.getLogger("gateway.mqtt")

TOKEN = "Command/Token"
#: The client a DCMD's principal and audit entry name (a broker has no caller address).
CLIENT = "mqtt"


class StopAxes(Protocol):
    """What DCMD calls (``gateway.service.axes.AxisService``)."""

    async def stop(self, ident: str, mode: StopMode) -> Any:
        """Stop the axis's controller."""

    def acknowledge(self, ident: str, kinds: Any) -> Any:
        """Clear the axis's latched errors."""


CommandResult = tuple[int, str]


class DeviceCommands:
    """Authorises, carries out and audits the DCMDs of one edge node."""

    def __init__(
        self,
        axes: StopAxes,
        identify: Identify,
        audit: Callable[[Mapping[str, Any]], object],
        ahead: WriteAhead | None = None,
    ) -> None:
        self.axes, self.identify, self.audit = axes, identify, audit
        #: writes the entry of an authorised DCMD before it acts (None: not written ahead)
        self.ahead = ahead

    @classmethod
    def serving(cls, services: Services, identify: Identify) -> DeviceCommands:
        """The DCMDs of ``services`` (the ones every face shares: a REST stop and an MQTT one
        go to the same axes), authorised by ``identify``, written ahead to the shared audit
        record."""
        audit = services.audit
        return cls(services.axes, identify, audit.record, ahead=audit.write_ahead)

    async def handle(
        self, topic: str, ctl: ControllerRef, labels: Mapping[str, str], metrics: dict[str, Value]
    ) -> CommandResult:
        """Carry out one DCMD to ``ctl`` (``labels``: axis label -> axis id); (status, text)."""
        began = time.perf_counter()
        token = metrics.pop(TOKEN, None)
        principal = self.identify(token, CLIENT) if isinstance(token, str) and token else None
        actions: list[tuple[str, str]] = []
        status, result = 200, "done"
        for name, value in metrics.items():
            parts = name.split("/")
            what = "/".join(parts[2:])
            if parts[0] != "Axis" or len(parts) < 3 or parts[1] not in labels:
                status, result = 422, f"{name}: not a command metric of {ctl.id}"
            elif what not in ("Stop", "Errors/Ack") or value is not True:
                status, result = 422, f"{name}: only Stop and Errors/Ack, written true"
            else:
                actions.append((labels[parts[1]], what))
        if principal is None:
            status, result = 401, "Command/Token: missing or unknown token"
        elif not principal.role.allows(Role.OPERATOR):
            status, result = 403, f"token {principal.name!r} ({principal.role}) is not an operator"
        elif not actions and status == 200:
            status, result = 422, "no command metric"
        intent: int | None = None
        if status == 200 and self.ahead is not None:
            assert principal is not None
            try:
                intent = await self.ahead(
                    _entry(principal, topic, metrics, "intent"),
                    motion=False,
                    stop=any(what == "Stop" for _, what in actions),
                )
            except GatewayError as exc:  # the entry cannot be written: nothing acts
                status, result = 503, f"{type(exc).__name__}: {exc}"
        if status == 200:
            try:
                for axis, what in actions:
                    if what == "Stop":
                        outcome = await self.axes.stop(axis, StopMode.DECELERATE)
                        result = str(getattr(outcome, "outcome", "done"))
                    else:
                        self.axes.acknowledge(axis, None)
            except GatewayError as exc:  # the loop is down, the device did not answer...
                status, result = 503, f"{type(exc).__name__}: {exc}"
        outcome = _entry(principal, topic, metrics, None)
        outcome.update(status=status, duration=round(time.perf_counter() - began, 6))
        outcome["result"] = result
        if intent is not None:
            outcome["intent"] = intent
        self.audit(outcome)
        if status != 200:
            log.warning("mqtt: DCMD %s refused (%d): %s", topic, status, result)
        return status, result


def _entry(
    principal: Principal | None, topic: str, metrics: Mapping[str, Value], event: str | None
) -> dict[str, Any]:
    """An entry of a DCMD (the record cuts a long body, with its SHA-256)."""
    entry: dict[str, Any] = {
        "time": _utc(),
        "token": principal.name if principal else None,
        "role": str(principal.role) if principal else None,
        "client": CLIENT,
        "method": "DCMD",
        "path": topic,
        "query": None,
        "body": dict(metrics),
    }
    if event is not None:
        entry["event"] = event
    return entry


def _utc() -> str:
    now = time.time()
    stamp = time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(now))
    return f"{stamp}.{int(now % 1 * 1000):03d}Z"
