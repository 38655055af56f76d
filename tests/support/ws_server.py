"""Fixtures of the API tests.

WebSocket (A-ws): ``make_ws_server(replay=, backlog=)`` serves the feed endpoint through a
real uvicorn server on 127.0.0.1 (port 0) in the test's event loop; the state cache behind it
is fed the way the loop scheduler feeds it (``StateCache.handle(ReplyObserved(...))``), so a
test decides exactly which changes happen. Every message a test client receives is checked
against the published schema (``ws_schema()``).
"""

from __future__ import annotations

import asyncio
import json
import socket
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

import jsonschema_rs
import pytest
import uvicorn
from fastapi import FastAPI
from websockets.asyncio.client import ClientConnection, connect

from gateway.api.security import AuthConfig, TokenBook, hash_token, install_security
from gateway.api.ws import endpoint as ws
from gateway.api.ws.asyncapi import asyncapi_document, json_schema_of
from gateway.api.ws.messages import ws_schema
from gateway.bus.events import ReplyObserved
from gateway.bus.state import StateCache
from gateway.protocol.command_text import parse
from gateway.service.config import WsSettings
from gateway.service.events import ServiceEvents
from gateway.service.feed import Feed
from gateway.service.runtime.simulated import simulated_config
from gateway.service.topology import Topology

VIEWER_TOKEN = "viewer-token-for-tests"
#: Real seconds a test waits for one message before it fails.
RECV_TIMEOUT = 10.0

_SCHEMA = ws_schema()
SERVER_VALIDATOR = jsonschema_rs.validator_for(
    {"$schema": _SCHEMA["$schema"], "$defs": _SCHEMA["$defs"], "$ref": "#/$defs/ServerMessage"}
)


#: The messages the AsyncAPI document says the gateway sends (openapi/asyncapi.json).
ASYNCAPI_VALIDATOR = jsonschema_rs.validator_for(json_schema_of(asyncapi_document(), "send"))


def check_server_message(text: str | bytes) -> dict[str, Any]:
    """Decode one server message and check it against the published schemas (websocket.json
    and the AsyncAPI document)."""
    message: dict[str, Any] = json.loads(text)
    errors = [e.message for e in SERVER_VALIDATOR.iter_errors(message)]
    assert not errors, f"{message} breaks openapi/websocket.json: {errors}"
    errors = [e.message for e in ASYNCAPI_VALIDATOR.iter_errors(message)]
    assert not errors, f"{message} breaks openapi/asyncapi.json: {errors}"
    return message


@dataclass
class CountingStats:
    """A stand-in for the metrics' WebSocket counters."""

    connected_total: int = 0
    disconnected_total: int = 0
    dropped_total: int = 0

    def connected(self) -> None:
        self.connected_total += 1

    def disconnected(self) -> None:
        self.disconnected_total += 1

    def dropped(self) -> None:
        self.dropped_total += 1


class WsClient:
    """A websockets client that checks every message it receives against the schema."""

    def __init__(self, conn: ClientConnection) -> None:
        self.conn = conn

    async def send(self, message: dict[str, Any] | str) -> None:
        await self.conn.send(message if isinstance(message, str) else json.dumps(message))

    async def recv(self, timeout: float = RECV_TIMEOUT) -> dict[str, Any]:
        return check_server_message(await asyncio.wait_for(self.conn.recv(), timeout))

    async def subscribe(self, *topics: str, **extra: Any) -> dict[str, Any]:
        """Subscribe and return the first answer (a snapshot, or the first replayed one)."""
        await self.send({"type": "subscribe", "topics": list(topics), **extra})
        return await self.recv()

    async def close(self) -> None:
        await self.conn.close()


@dataclass
class WsServer:
    """The feed behind a real uvicorn server, and the cache that drives it."""

    cache: StateCache
    events: ServiceEvents
    feed: Feed
    stats: CountingStats
    port: int
    clients: list[WsClient] = field(default_factory=list)
    clock: float = 1000.0  # the scheduler clock the test's replies carry

    def url(self, token: str | None = VIEWER_TOKEN) -> str:
        query = "" if token is None else f"?token={token}"
        return f"ws://127.0.0.1:{self.port}/api/v1/ws{query}"

    async def connect(self, token: str | None = VIEWER_TOKEN, **kwargs: Any) -> WsClient:
        kwargs.setdefault("compression", None)
        kwargs.setdefault("open_timeout", RECV_TIMEOUT)
        kwargs.setdefault("close_timeout", 2.0)
        client = WsClient(await connect(self.url(token), **kwargs))
        self.clients.append(client)
        return client

    def position(self, body: str, motor: int, pulses: int) -> None:
        """The scheduler decoded a ``6{mt}`` reply: the axis is at ``pulses`` (§10 6)."""
        self.clock += 0.05
        command = parse(f"6{motor}")
        self.cache.handle(
            ReplyObserved(loop="sim", time=self.clock, body=body, command=command, value=pulses)
        )


async def start_uvicorn(
    app: FastAPI, *, sndbuf: int | None = None, **options: Any
) -> tuple[uvicorn.Server, int]:
    """A uvicorn server for ``app`` on 127.0.0.1, an ephemeral port, in this event loop.

    ``sndbuf``: the kernel send buffer of every accepted socket (they inherit it from the
    listening one). Left alone, Linux lets it grow to megabytes on loopback, which a test of
    a client that stops reading would have to fill before the gateway's own backlog counts.
    """
    options = {"ws_per_message_deflate": False, "log_level": "warning", **options}
    config = uvicorn.Config(app, lifespan="off", **options)
    config.load()
    server = uvicorn.Server(config)
    server.lifespan = config.lifespan_class(config)
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if sndbuf is not None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, sndbuf)
    sock.bind(("127.0.0.1", 0))
    await server.startup(sockets=[sock])
    return server, int(sock.getsockname()[1])


def ws_app(feed: Feed, auth: AuthConfig, stats: CountingStats) -> FastAPI:
    """A FastAPI app with the WebSocket router alone (as create_app mounts it)."""
    app = FastAPI()
    install_security(app, auth)
    ws.install_ws(app, feed, "/api/v1")
    app.state.metrics = stats
    return app


MakeWsServer = Callable[..., Awaitable[WsServer]]


@pytest.fixture
async def make_ws_server() -> AsyncIterator[MakeWsServer]:
    """``await make_ws_server(replay=, backlog=, sndbuf=)``: a served feed on simulated_config's
    topology (loop ``sim``, bodies 1 and 2: axes x, y, z, theta), the cache empty."""
    servers: list[tuple[uvicorn.Server, WsServer]] = []

    async def make(
        replay: int = 10_000, backlog: int = 1_000, sndbuf: int | None = None, **options: Any
    ) -> WsServer:
        token = {"name": "dashboard", "role": "viewer", "sha256": hash_token(VIEWER_TOKEN)}
        config = simulated_config(("1", "2"), tokens=[token])
        cache, events, stats = StateCache(), ServiceEvents(), CountingStats()
        settings = WsSettings(replay=replay, backlog=backlog)
        feed = Feed(Topology(config), cache, events, settings, clock=time.time)
        auth = AuthConfig(TokenBook.from_settings(config.security.tokens))
        server, port = await start_uvicorn(ws_app(feed, auth, stats), sndbuf=sndbuf, **options)
        served = WsServer(cache, events, feed, stats, port)
        servers.append((server, served))
        return served

    yield make
    for server, served in servers:
        await asyncio.gather(*(client.close() for client in served.clients))
        served.feed.close()
        await server.shutdown()
