"""The real app on an in-process simulated loop, for the API tests.

``async with running_app() as api:`` builds the simulated loop of ``serve --simulate``
(bodies 1, 2, 3; axes x, y, z, theta, gripper, conveyor; ``SCALE`` times faster than real
time), the gateway on it through ``PipeTransport`` (the gateway's real serial code path minus
the OS), its services from ``compose`` and the app from ``create_app``; it runs the app's
lifespan (loops and polling start), waits until the poller has read every controller, and
gives an httpx client on it. Without
``roles`` the API runs without authentication; with ``roles=True`` every request needs one of
``TOKENS``; ``audit_log`` is the audit log's file; ``config`` replaces the simulated one.
``api.heard(body)`` is what the simulated controller heard, from the simulator's own line
log, so a test asserts the bytes on the wire.

``async with running_services() as gw:`` is the same gateway without the app: the services of
``compose``, started and identified, for tests that call ``gateway.service`` directly.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable, Sequence
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
from fastapi import FastAPI

from gateway.api.app import create_app
from gateway.api.security import AuthConfig, TokenBook, TokenEntry, hash_token
from gateway.bus.state_types import ControllerState
from gateway.cli.serve import sim_line
from gateway.compose import compose
from gateway.protocol.command_text import parse
from gateway.protocol.spec import Effect
from gateway.service.config import GatewayConfig
from gateway.service.events import ServiceEvent
from gateway.service.leases import Leases
from gateway.service.operations.book import Operations
from gateway.service.roles import Role
from gateway.service.runtime.runtime import Runtime
from gateway.service.runtime.simulated import SIM_LOOP, simulated_config
from gateway.service.services import Services
from gateway.service.store import StateStore
from gateway.sim.cli import build_loop
from gateway.sim.clock import RecordKind, SimClock
from gateway.sim.loop import SimLoop
from tests.support.state_waits import until_state

#: Device seconds per real second in the API tests.
SCALE = 50.0
BASE = "http://localhost/api/v1"
#: Real seconds a test waits for something the gateway does on its own (polls, a motion end).
WAIT = 20.0
#: The tokens of ``running_app(roles=True)``: name -> (token, role); one per role, named
#: after it, and two operators to tell clients apart (leases).
TOKENS: dict[str, tuple[str, Role]] = {
    "viewer": ("tok-viewer", Role.VIEWER),
    "operator": ("tok-operator", Role.OPERATOR),
    "admin": ("tok-admin", Role.ADMIN),
    "alice": ("tok-alice", Role.OPERATOR),
    "bob": ("tok-bob", Role.OPERATOR),
}


async def declare_json(request: httpx.Request) -> None:
    """Declare JSON on every request that acts and declares nothing, as the dashboard does
    (the gateway refuses a POST, PUT, PATCH or DELETE declared otherwise, bodyless too)."""
    if request.method in ("POST", "PUT", "PATCH", "DELETE"):
        request.headers.setdefault("Content-Type", "application/json")


#: ``event_hooks=`` of an httpx client that declares JSON like the dashboard
DECLARE_JSON: dict[str, list[Any]] = {"request": [declare_json]}


def auth(name: str | Role) -> dict[str, str]:
    """The Authorization header of the test token ``name`` (or of the token named after a role)."""
    return {"Authorization": f"Bearer {TOKENS[str(name)][0]}"}


def json_of(response: httpx.Response) -> Any:
    """The JSON body, with the response in the assertion message when it is not JSON."""
    assert response.headers.get("content-type", "").endswith("json"), response.text
    return response.json()


@dataclass
class SimGateway:
    """A running gateway's services (``compose``), its runtime and the simulated loop behind
    it, for tests that call ``gateway.service`` directly (``running_services``)."""

    runtime: Runtime
    sim: SimLoop
    events: list[ServiceEvent]
    #: what the faces serve (``compose``): the very objects REST, MQTT and OPC UA are given
    services: Services

    @property
    def leases(self) -> Leases:
        """The app's control leases."""
        return self.services.leases

    @property
    def operations(self) -> Operations:
        """The app's operations."""
        return self.services.operations

    @property
    def bodies(self) -> list[str]:
        """The simulated bodies."""
        return [u.name for u in self.sim.units]

    def mark(self) -> int:
        """The simulator's line-log position now (for ``heard(since=...)``)."""
        return self.sim.log.next_seq

    def heard(self, body: str = "1", since: int = 0) -> list[str]:
        """The command texts controller ``body`` heard (since ``mark``), in order."""
        return [
            r.data[2:].rstrip(b"\r").decode("latin-1")
            for r in self.sim.log.since(since)
            if r.kind is RecordKind.HEARD and r.ref > 0 and r.body == body
        ]

    def acted(self, body: str = "1", since: int = 0) -> list[str]:
        """What controller ``body`` heard (since ``mark``) that changes something: every
        command but the queries (the poller's reads), as the catalog classes them."""
        return [t for t in self.heard(body, since) if parse(t).form.effect is not Effect.QUERY]

    def device(self, body: str = "1") -> Any:
        """The simulated controller at ``body``."""
        return self.sim.unit(body).device

    def position(self, body: str = "1", motor: int = 1) -> int:
        """The simulated motor's position counter now (read through ``act``: after whatever
        is due on the simulated line, so the simulator's time never goes back)."""
        seen: list[int] = []
        device = self.device(body)
        self.sim.act(lambda now: seen.append(device.snapshot(now)["axes"][str(motor)]["position"]))
        return int(seen[0])

    def cached(self, body: str = "1") -> ControllerState:
        """The state cache's record of controller ``body``."""
        return self.runtime.state.controller(SIM_LOOP, body)

    async def until(self, check: Callable[[], bool], timeout: float = WAIT) -> None:
        """Wait until ``check()`` holds, woken by the state cache's changes (no sleeping)."""
        await until_state(self.runtime.state, check, timeout)

    async def identified(self, bodies: Sequence[str] | None = None) -> None:
        """Every controller read once by the poller (mode known, positions read)."""
        state = self.runtime.state

        def done() -> bool:
            return all(
                state.controller(SIM_LOOP, b).mode is not None
                and state.axis(SIM_LOOP, b, 1).position is not None
                for b in (bodies or self.bodies)
            )

        await self.until(done)


@dataclass
class Api(SimGateway):
    """A running app, its gateway, the simulated loop behind it and a client."""

    app: FastAPI
    client: httpx.AsyncClient


@dataclass
class _Simulated:
    """What both rigs build: the simulated loop, the runtime on it, its services, and the
    service events recorded."""

    sim: SimLoop
    runtime: Runtime
    services: Services
    events: list[ServiceEvent]


def _simulated(
    bodies: Sequence[str],
    scale: float,
    eeprom_dir: Path | None,
    config: GatewayConfig | None,
    store: StateStore | None,
) -> _Simulated:
    sim = build_loop(list(bodies), clock=SimClock(scale), eeprom_dir=eeprom_dir)
    config = config or simulated_config(bodies)
    # The in-process line of ``serve --simulate``: a port reopened at another rate (POST
    # /loops/{loop}/baud) sets the simulated line's, and controllers at another rate hear noise.
    line = sim_line(sim)
    runtime = Runtime(config, transports={SIM_LOOP: line}, time_scale=scale, store=store)
    events: list[ServiceEvent] = []
    runtime.events.subscribe(events.append)
    return _Simulated(sim, runtime, compose(runtime), events)


@asynccontextmanager
async def running_services(
    bodies: Sequence[str] = ("1", "2", "3"),
    *,
    scale: float = SCALE,
    config: GatewayConfig | None = None,
) -> AsyncIterator[SimGateway]:
    """The services of ``compose`` on a simulated loop, started as the app's lifespan starts
    them and identified; closed after the block. No app, no HTTP: the caller is the service."""
    made = _simulated(bodies, scale, None, config, None)
    try:
        await made.services.start()
        try:
            gateway = SimGateway(made.runtime, made.sim, made.events, made.services)
            await gateway.identified()
            yield gateway
        finally:
            await made.services.close()
    finally:
        made.sim.close()


@asynccontextmanager
async def running_app(
    bodies: Sequence[str] = ("1", "2", "3"),
    *,
    scale: float = SCALE,
    roles: bool = False,
    eeprom_dir: Path | None = None,
    audit_log: Path | None = None,
    config: GatewayConfig | None = None,
    cache_last: bool = False,
    store: StateStore | None = None,
) -> AsyncIterator[Api]:
    """The app on a simulated loop, started and identified; closed after the block.

    ``cache_last``: the state cache hears each scheduler event after every other subscriber
    rather than first (no answer may depend on the order)."""
    config = config or simulated_config(bodies)
    if audit_log is not None:
        config = config.model_copy(update={"audit_log": audit_log})
    made = _simulated(bodies, scale, eeprom_dir, config, store)
    if roles:
        book = TokenBook(TokenEntry(n, role, hash_token(t)) for n, (t, role) in TOKENS.items())
        auth = AuthConfig(book)
    else:
        auth = AuthConfig(no_auth=True)
    app = create_app(made.services, auth=auth)
    if cache_last:
        for scheduler in made.runtime.schedulers.values():
            scheduler.use_state(made.runtime.state, first=False)
    try:
        async with app.router.lifespan_context(app):
            transport = httpx.ASGITransport(app=app)
            async with httpx.AsyncClient(
                transport=transport, base_url=BASE, timeout=WAIT, event_hooks=DECLARE_JSON
            ) as client:
                api = Api(
                    made.runtime, made.sim, made.events, made.services, app=app, client=client
                )
                await api.identified()
                yield api
    finally:
        made.sim.close()
