"""Fresh reads shared fairly: a few on the line per caller, the rest answered from the cache.

``GET /axes/{id}?fresh=true`` and ``GET /controllers/{id}?fresh=true`` put reads on the
line, which every poll, motion and stop of the loop shares. One viewer asking them in a loop
from thirty threads kept thirty reads queued: other callers' fresh reads waited most of a
second and the poller's readings of the other axes went seconds old. ``FreshReadGate`` (a pure
ASGI layer around the cached read) lets each caller (the token's name; ``anonymous`` in the
open mode) have ``FRESH_PER_CALLER`` fresh reads under way at a time. A fresh read beyond that
is answered as the plain read is, from the state cache, with what says so:

* ``Cache-Status: rc233-gateway; hit; detail=fresh-read-limit`` (RFC 9211): not read now;
* ``Age``: whole seconds since the cached reading (RFC 9111; the view's ``updated`` too).

So a caller gets an answer at once either way, and nobody's reads can crowd out the line.
A request the routed read would refuse (no token, an unknown one) goes on unchanged.
"""

from __future__ import annotations

import json
import math
import time
from urllib.parse import parse_qsl, urlencode

from starlette.datastructures import MutableHeaders
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from gateway.api.security import auth_of_scope, bearer_of_headers

__all__ = ["CACHE_STATUS", "FRESH_PER_CALLER", "FreshReadGate"]

#: fresh reads one caller may have under way at a time
FRESH_PER_CALLER = 2
#: how an answer from the cache instead of the line says so (RFC 9211)
CACHE_STATUS = "rc233-gateway; hit; detail=fresh-read-limit"
_TRUE = frozenset({"true", "1", "yes", "on", "t", "y"})  # what FastAPI reads as True


def _wants_fresh(query: bytes) -> bool:
    if b"fresh" not in query:
        return False
    pairs = parse_qsl(query.decode("latin-1"), keep_blank_values=True)
    return any(name == "fresh" and value.lower() in _TRUE for name, value in pairs)


def _without_fresh(query: bytes) -> bytes:
    pairs = parse_qsl(query.decode("latin-1"), keep_blank_values=True)
    return urlencode([(n, v) for n, v in pairs if n != "fresh"]).encode("latin-1")


class FreshReadGate:
    """At most ``FRESH_PER_CALLER`` fresh reads under way per caller (see the module)."""

    def __init__(self, app: ASGIApp, prefix: str, per_caller: int = FRESH_PER_CALLER) -> None:
        self.app = app
        self.starts = (f"{prefix}/axes/", f"{prefix}/controllers/")
        self.per_caller = per_caller
        #: fresh reads under way per caller; a caller's entry goes with its last read, so
        #: the table holds the callers reading now and nothing of those who left
        self._under_way: dict[str, int] = {}

    @property
    def callers(self) -> int:
        """Callers with a fresh read under way now."""
        return len(self._under_way)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """The ASGI entry point."""
        if (
            scope["type"] != "http"
            or scope["method"] != "GET"
            or not scope["path"].startswith(self.starts)
            or not _wants_fresh(scope.get("query_string", b""))
        ):
            await self.app(scope, receive, send)
            return
        principal = auth_of_scope(scope).authenticate(bearer_of_headers(scope), "")
        if principal is None:  # the routed read answers the problem
            await self.app(scope, receive, send)
            return
        caller = principal.name
        under_way = self._under_way.get(caller, 0)
        if under_way >= self.per_caller:
            cached = {**scope, "query_string": _without_fresh(scope.get("query_string", b""))}
            await _answer_cached(self.app, cached, receive, send)
            return
        self._under_way[caller] = under_way + 1
        try:
            await self.app(scope, receive, send)
        finally:
            left = self._under_way[caller] - 1
            if left:
                self._under_way[caller] = left
            else:
                del self._under_way[caller]


async def _answer_cached(app: ASGIApp, scope: Scope, receive: Receive, send: Send) -> None:
    """The plain read's answer, with ``Cache-Status`` and ``Age`` (from the view's
    ``updated``): the start is held until the body, a view of a few hundred bytes, is seen."""
    start: Message | None = None
    body = bytearray()

    async def send_marked(message: Message) -> None:
        nonlocal start
        if message["type"] == "http.response.start":
            start = message
            return
        if message["type"] == "http.response.body" and start is not None:
            body.extend(message.get("body", b""))
            if message.get("more_body", False):
                return
            headers = MutableHeaders(scope=start)
            headers["Cache-Status"] = CACHE_STATUS
            age = _age(bytes(body)) if start["status"] == 200 else None
            if age is not None:
                headers["Age"] = str(age)
            await send(start)
            await send({"type": "http.response.body", "body": bytes(body), "more_body": False})
            start = None
            return
        await send(message)

    await app(scope, receive, send_marked)


def _age(body: bytes) -> int | None:
    try:
        updated = json.loads(body).get("updated")
    except (ValueError, AttributeError):
        return None
    if not isinstance(updated, int | float):
        return None
    return max(0, math.floor(time.time() - updated))
