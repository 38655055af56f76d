"""Who may even ask: the ``Host`` a request names and the site a browser says it came from.

A browser lets any web page send requests to any address, the gateway's on loopback
included; it only keeps the page from reading most answers. A request that acts is done by
then. Two rules close that door, in every mode (``--no-auth`` too), before anything else of
the API runs (``RequestGuard``, a pure ASGI layer):

* **Host**: the ``Host`` header names the gateway: a loopback name or address (``localhost``,
  ``*.localhost``, ``127.0.0.1``, ``[::1]``), the address the connection came in on, or one
  of ``security.allowed_hosts``; any port.
  A page served from a name of its own that resolves to the gateway (DNS rebinding) names
  its own host, and is refused ``421`` (``400`` without a ``Host``), reads and the dashboard
  included, and so is a WebSocket upgrade.
* **Origin**: a request that acts (POST, PUT, PATCH, DELETE) and a WebSocket upgrade are
  refused ``403`` when the browser says another site sent it: an ``Origin`` that is not the
  gateway's own (the name and port of the ``Host`` it asked) nor one of
  ``security.cors_origins``, ``Origin: null`` (a sandboxed frame, a file), or
  ``Sec-Fetch-Site`` other than ``same-origin`` / ``none`` without an allowed ``Origin``.
  Clients that are not browsers send neither header and are not concerned.

The third rule, ``Content-Type: application/json`` on every request that acts (the kind a
browser cannot send across sites without asking first), is the body gate's
(``gateway.api.middleware.body_gate``). A refused WebSocket is refused before it is accepted: the
client sees HTTP 403 and no byte of the feed.
"""

from __future__ import annotations

import ipaddress
import logging
from collections.abc import Iterable
from dataclasses import dataclass
from urllib.parse import urlsplit

from starlette.types import ASGIApp, Receive, Scope, Send

from gateway.api.problems import Problem, problem_response, problem_type

__all__ = ["ACTING_METHODS", "HostRule", "OriginRule", "RequestGuard", "host_name"]

log = logging.getLogger("gateway.api")

ACTING_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})
#: what ``Sec-Fetch-Site`` says of a request the user made on the gateway's own pages (or
#: typed, bookmarked): anything else came from another site
_OWN_SITE = frozenset({"same-origin", "none"})
_DEFAULT_PORTS = {"http": 80, "https": 443, "ws": 80, "wss": 443}


def host_name(authority: str) -> str:
    """The host of a ``Host`` header (``gw:8233`` -> ``gw``, ``[::1]:80`` -> ``::1``),
    lower case, without a trailing dot."""
    text = authority.strip().lower()
    if text.startswith("["):
        end = text.find("]")
        return text[1:end] if end > 0 else text
    if text.count(":") == 1:
        text = text.split(":", 1)[0]
    return text.rstrip(".")


def _is_loopback_name(name: str) -> bool:
    if name == "localhost" or name.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def _is_own_address(scope: Scope, authority: str) -> bool:
    """True when ``authority`` is the address the connection came in on (an address, never
    a name: a rebound name cannot be one), so ``http://192.0.2.7:8233`` works unconfigured."""
    server = scope.get("server")
    if not server:
        return False
    try:
        local = ipaddress.ip_address(str(server[0]))
        return ipaddress.ip_address(host_name(authority)) == local
    except ValueError:
        return False


class HostRule:
    """The names the ``Host`` header may give: loopback ones and ``allowed`` (``*``: any)."""

    def __init__(self, allowed: Iterable[str] = ()) -> None:
        names = {host_name(a) for a in allowed}
        self.any = "*" in names
        self.names = frozenset(names - {"*"})

    def allows(self, authority: str) -> bool:
        """True when ``authority`` (a ``Host`` header) names the gateway."""
        if self.any:
            return True
        name = host_name(authority)
        return bool(name) and (name in self.names or _is_loopback_name(name))


def _origin_key(scheme: str, host: str, port: int | None) -> tuple[str, str, int]:
    scheme = {"ws": "http", "wss": "https"}.get(scheme, scheme)
    return scheme, host, port if port is not None else _DEFAULT_PORTS.get(scheme, 0)


def _parse_origin(origin: str) -> tuple[str, str, int] | None:
    try:
        parts = urlsplit(origin.strip().lower())
        port = parts.port
    except ValueError:
        return None
    if not parts.scheme or not parts.hostname:
        return None
    return _origin_key(parts.scheme, parts.hostname, port)


class OriginRule:
    """Which browser origins may act: the gateway's own and ``allowed`` (``cors_origins``)."""

    def __init__(self, allowed: Iterable[str] = ()) -> None:
        keys = {_parse_origin(a) for a in allowed}
        self.allowed = frozenset(k for k in keys if k is not None)

    def refusal(self, scope: Scope, headers: dict[bytes, str]) -> str | None:
        """Why the request of ``scope`` comes from another site (None: it does not)."""
        origin = headers.get(b"origin")
        site = headers.get(b"sec-fetch-site", "").strip().lower()
        if origin is None:
            if site and site not in _OWN_SITE:
                return f"Sec-Fetch-Site: {site} (a page of another site sent it)"
            return None
        key = _parse_origin(origin)
        if key is not None and key in self.allowed:
            return None
        if key is None:
            return f"Origin {origin[:80]!r} is no site of its own (a sandboxed frame or file)"
        if not _is_own_origin(key, headers.get(b"host", "")):
            return f"Origin {origin[:80]} is another site than the gateway's"
        if site and site not in _OWN_SITE:
            return f"Sec-Fetch-Site: {site} (a page of another site sent it)"
        return None


def _is_own_origin(origin: tuple[str, str, int], host: str) -> bool:
    """True when ``origin`` is the gateway's own page as the ``Host`` it asked names it: the
    same name, and the same port. A ``Host`` without a port was reached on a default port
    (80, or 443 through a TLS proxy that passes the client's ``Host``), so then the page's
    port is 80 or 443; the scheme is not compared, since behind such a proxy the gateway
    itself speaks plain HTTP."""
    parts = urlsplit(f"//{host.strip().lower()}")
    try:
        port = parts.port
    except ValueError:
        return False
    if (parts.hostname or "") != origin[1]:
        return False
    return origin[2] == port if port is not None else origin[2] in (80, 443)


@dataclass(frozen=True)
class _Refusal:
    status: int
    slug: str
    title: str
    field: str
    rule: str
    detail: str


class RequestGuard:
    """Refuse requests to another host, and acts (and WebSockets) from another site."""

    def __init__(
        self, app: ASGIApp, allowed_hosts: Iterable[str] = (), cors_origins: Iterable[str] = ()
    ) -> None:
        self.app = app
        self.hosts = HostRule(allowed_hosts)
        self.origins = OriginRule(cors_origins)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """The ASGI entry point."""
        kind = scope["type"]
        if kind not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        refusal = self.refusal(scope)
        if refusal is None:
            await self.app(scope, receive, send)
            return
        if kind == "websocket":
            # uvicorn writes the refused upgrade's line (403); the reason costs a line only at -v.
            log.debug("WebSocket refused before its handshake: %s", refusal.detail)
            await receive()  # websocket.connect
            # A close before the accept: the server answers the upgrade with HTTP 403.
            await send({"type": "websocket.close", "code": 1008, "reason": refusal.detail})
            return
        problem = Problem(
            type=problem_type(refusal.slug),
            title=refusal.title,
            status=refusal.status,
            detail=f"{refusal.field}: {refusal.detail}",
            instance=scope.get("path"),
            field=refusal.field,
            rule=refusal.rule,
        )
        await problem_response(problem)(scope, receive, send)

    def refusal(self, scope: Scope) -> _Refusal | None:
        """Why the request of ``scope`` is refused here (None: it goes on)."""
        headers: dict[bytes, str] = {}
        for name, value in scope.get("headers", ()):
            key = bytes(name).lower()
            if key in (b"host", b"origin", b"sec-fetch-site") and key not in headers:
                headers[key] = bytes(value).decode("latin-1")
        host = headers.get(b"host")
        host_rule = "a loopback name or address, or one of security.allowed_hosts"
        if not host:
            return _Refusal(400, "bad-request", "Bad request", "header.host", host_rule,
                            "the request names no host")  # fmt: skip
        if not self.hosts.allows(host) and not _is_own_address(scope, host):
            return _Refusal(
                421, "misdirected-request", "Misdirected request", "header.host", host_rule,
                f"{host[:80]!r} is not a name of this gateway",
            )  # fmt: skip
        acting = scope["type"] == "websocket" or scope.get("method") in ACTING_METHODS
        why = self.origins.refusal(scope, headers) if acting else None
        if why is not None:
            return _Refusal(
                403, "cross-site", "Cross-site request refused", "header.origin",
                "requests that act come from the gateway's own pages or security.cors_origins",
                why,
            )  # fmt: skip
        return None
