"""The WebSocket ``/api/v1/ws``: the feed (``gateway.service.feed``) to dashboards.

One connection, one feed client. Decisions (see ``ws_messages.CLOSE_CODES``):

* Authentication uses the REST tokens (``Authorization: Bearer``, or ``?token=`` for browsers,
  which cannot set headers on a WebSocket); any role may subscribe. The handshake is
  accepted and then closed with 4401 (no or unknown token) or 4403 (role too weak), because
  a browser sees a close code but never the status of a refused handshake. Wrong tokens
  count towards the address's back-off as on HTTP (``gateway.api.auth_failures``): while it
  waits, the handshake is closed with 4429 before its token is looked at. A page of another
  site, or a name that is not the gateway's, is refused before the handshake is accepted
  (``gateway.api.middleware.request_guard``: HTTP 403).
* Client messages are JSON text: ``subscribe`` (topics, optional ``since``/``stream`` to
  resume), ``unsubscribe``, ``ping``. A message that does not fit is answered with an
  ``error`` naming the field and the rule; the connection stays open.
* A message goes straight to the client's socket when nothing is queued ahead of it and the
  socket takes data (``gateway.api.ws.direct``: no task switch per client); otherwise one
  sender task per connection takes the client's queue in order and writes it; it alone
  waits on a slow socket. When the queue overflows (``ws.backlog`` unsent messages) the feed
  drops the client at once and this handler closes the connection with 4008 "backlog
  exceeded" (counted as dropped in the metrics). Nobody else waits for it.
* A client message longer than ``WS_MESSAGE_LIMIT`` bytes is refused by the server as its
  frame header arrives (uvicorn ``ws_max_size``): the connection is closed with 1009
  "message too big" before the message is read. The longest message a client needs (a
  subscribe to every resource) is a few kilobytes.
* Keepalive is the WebSocket protocol's own ping, sent by the server (uvicorn
  ``ws_ping_interval``, see ``uvicorn_ws_options``): every client library answers it
  without application code, and a peer that stops answering is closed (1011).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from typing import Any, Protocol

from fastapi import FastAPI, WebSocket
from pydantic import ValidationError

from gateway.api.auth_failures import failures_of
from gateway.api.security import AuthConfig, authenticate_websocket, bearer_of_headers
from gateway.api.ws.direct import DirectWriter, direct_writer
from gateway.api.ws.messages import (
    ClientMessage,
    PingMessage,
    SubscribeMessage,
)
from gateway.errors import InvalidInputError
from gateway.service.config import WsSettings
from gateway.service.feed import Feed, FeedClient
from gateway.service.roles import Role

__all__ = [
    "CLOSE_TIMEOUT",
    "WS_MESSAGE_LIMIT",
    "WsCounter",
    "install_ws",
    "serve_client",
    "uvicorn_ws_options",
]

log = logging.getLogger("gateway.api")

#: Bytes a client message may have (a frame announcing more is refused with 1009).
WS_MESSAGE_LIMIT = 64 * 1024
#: Seconds a close may wait for a socket that does not drain (a client that stopped reading).
CLOSE_TIMEOUT = 10.0


class WsCounter(Protocol):
    """What the handler tells the metrics (``gateway.api.metrics.collector.WsStats``)."""

    def connected(self) -> None:
        """A client was accepted."""

    def disconnected(self) -> None:
        """A client left (for whatever reason)."""

    def dropped(self) -> None:
        """A client was closed because it did not read (4008)."""


def uvicorn_ws_options(settings: WsSettings) -> dict[str, Any]:
    """Keyword arguments of ``uvicorn.Config`` for the feed: protocol pings every
    ``ping_interval`` (a client silent as long again is closed), client messages of at most
    ``WS_MESSAGE_LIMIT`` bytes, and no per-message deflate, which would compress every
    message once per client instead of once."""
    return {
        "ws_max_size": WS_MESSAGE_LIMIT,
        "ws_ping_interval": settings.ping_interval,
        "ws_ping_timeout": settings.ping_interval,
        "ws_per_message_deflate": False,
    }


def install_ws(app: FastAPI, feed: Feed, prefix: str = "/api/v1") -> None:
    """Serve ``feed`` at ``{prefix}/ws``: the endpoint holds the feed it is given."""

    async def websocket_feed(websocket: WebSocket) -> None:
        """Subscribe to axes, controllers, loops and events (see ``openapi/websocket.json``)."""
        await serve_client(websocket, feed, stats=_stats(websocket.app.state))

    app.add_api_websocket_route(f"{prefix}/ws", websocket_feed)


def _stats(state: Any) -> WsCounter | None:
    metrics = getattr(state, "metrics", None)
    stats = getattr(metrics, "ws", metrics)
    needed = ("connected", "disconnected", "dropped")
    return stats if all(callable(getattr(stats, n, None)) for n in needed) else None


async def serve_client(
    ws: WebSocket, feed: Feed, *, stats: WsCounter | None = None, backlog: int | None = None
) -> None:
    """Run one connection: authenticate, then feed it until either side ends it."""
    auth = getattr(ws.app.state, "auth", None)
    auth = auth if isinstance(auth, AuthConfig) else AuthConfig()
    failures = None if auth.no_auth else failures_of(ws.scope)
    address = ws.client.host if ws.client else "unknown"
    wait = failures.retry_after(address) if failures is not None else None
    if failures is not None and wait is not None:
        # As for HTTP: refused before the token is looked at (gateway.api.auth_failures).
        failures.throttled(address, f"WebSocket {ws.url.path}")
        await ws.accept()
        await ws.close(4429, f"too many failed authentications: retry in {math.ceil(wait)} s")
        return
    principal = authenticate_websocket(ws, auth)
    await ws.accept()
    if principal is None:
        if failures is not None:
            given = bool(bearer_of_headers(ws.scope) or ws.query_params.get("token"))
            failures.failed(address, f"WebSocket {ws.url.path}", guessed=given)
        await ws.close(4401, "missing or unknown token")
        return
    if failures is not None:
        failures.succeeded(address)
    if not principal.role.allows(Role.VIEWER):
        await ws.close(4403, f"the {principal.role} role may not subscribe")
        return
    client = feed.open(backlog)
    client.direct = _direct_writer(ws)
    if stats:
        stats.connected()
    tasks = [
        asyncio.create_task(_send(ws, client)),
        asyncio.create_task(_receive(ws, client)),
        asyncio.create_task(client.ended.wait()),
    ]
    try:
        await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    finally:
        gone = tasks[1].done()  # the client closed or vanished: nothing to close
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        client.close()
        if client.dropped and stats:
            stats.dropped()
        if stats:
            stats.disconnected()
    if client.dropped:
        log.warning("WebSocket client %s dropped: backlog exceeded", principal.client)
        await _close(ws, 4008, "backlog exceeded")
    elif not gone:
        await _close(ws, 1001, "the gateway is shutting down")


def _direct_writer(ws: WebSocket) -> DirectWriter | None:
    """The connection's direct writer; None on a server it does not know, or when finding
    it fails in any way (Starlette keeps the ASGI ``send`` in a private attribute)."""
    try:
        return direct_writer(getattr(ws, "_send", None))
    except Exception:
        log.warning("no direct WebSocket writer: messages go through ASGI send", exc_info=True)
        return None


async def _close(ws: WebSocket, code: int, reason: str) -> None:
    # The close frame queues behind what the socket still holds: a client that stopped
    # reading gets it when it reads again, or the wait ends and uvicorn closes the socket.
    with contextlib.suppress(Exception):
        await asyncio.wait_for(ws.close(code, reason), CLOSE_TIMEOUT)


async def _send(ws: WebSocket, client: FeedClient) -> None:
    """The client's queue, in order, to its socket (the only task that waits on it)."""
    while True:
        text = await client.get()
        client.sending = True  # no direct write may overtake this one
        try:
            await ws.send_text(text)
        finally:
            client.sending = False


async def _receive(ws: WebSocket, client: FeedClient) -> None:
    """The client's messages until it closes."""
    while True:
        message = await ws.receive()
        if message["type"] == "websocket.disconnect":
            return
        text = message.get("text")
        if text is None:
            _error(client, None, "messages are JSON text frames", "a binary frame")
            continue
        handle_message(client, text)


def handle_message(client: FeedClient, text: str) -> None:
    """Act on one client message; what does not fit is answered with ``error``."""
    try:
        message = ClientMessage.model_validate_json(text).root
    except ValidationError as exc:
        field, rule = _first_error(exc)
        _error(client, field, rule, f"{field or 'message'}: {rule}")
        return
    try:
        if isinstance(message, SubscribeMessage):
            client.subscribe(message.topics, message.since, message.stream)
        elif isinstance(message, PingMessage):
            client.reply({"type": "pong", "id": message.id})
        else:
            topics = client.unsubscribe(message.topics)
            client.reply({"type": "unsubscribed", "topics": topics})
    except InvalidInputError as exc:
        _error(client, exc.field, exc.rule, str(exc))


_KINDS = ("subscribe", "unsubscribe", "ping")


def _first_error(exc: ValidationError) -> tuple[str | None, str]:
    """The field (``topics[0]``) and rule of a refused message's first error."""
    err = exc.errors(include_url=False)[0]
    loc = list(err["loc"])
    if err["type"] == "json_invalid":
        return None, "a message is one JSON object"
    if err["type"] in ("union_tag_not_found", "union_tag_invalid", "model_attributes_type"):
        if err["type"] == "model_attributes_type":
            return None, "a message is one JSON object"
        return "type", f"type is one of {', '.join(_KINDS)}"
    if loc and loc[0] in _KINDS:  # the discriminated union puts the tag first
        loc = loc[1:]
    field = ""
    for part in loc:
        field += f"[{part}]" if isinstance(part, int) else (f".{part}" if field else str(part))
    rule = err["msg"]
    if err["type"] == "extra_forbidden":
        rule = "not a field of this message"
    return field or None, rule


def _error(client: FeedClient, field: str | None, rule: str, detail: str) -> None:
    client.reply({"type": "error", "field": field, "rule": rule, "detail": detail})
