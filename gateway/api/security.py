"""Bearer tokens and roles : who is calling, and may they.

Tokens are stored only as SHA-256 hex digests (``hash_token``; config ``security.tokens``),
each with a name (what the audit log records) and a role. Roles are ordered: viewer (read,
subscribe) < operator (motion, settings, leases) < admin (raw, EEPROM, programs, mode,
framing, line trace). A route states what it needs with the dependency ``require(Role.X)``,
which returns the caller's ``Principal``; a missing or unknown token is a 401 problem with
``WWW-Authenticate: Bearer``, a token too weak a 403 problem naming the role needed.

No-auth mode (``serve --no-auth``, and only then): every caller is
``Principal("anonymous", admin, client)``. ``AuthConfig.decide`` applies the rule that it is
allowed on loopback only.
"""

from __future__ import annotations

import hashlib
import hmac
import ipaddress
import math
import re
import secrets
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from functools import cache
from typing import Annotated, Any, Protocol

from fastapi import FastAPI, Request, Security, WebSocket
from fastapi.routing import APIRoute
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from starlette.requests import HTTPConnection
from starlette.routing import BaseRoute
from starlette.types import Scope

try:  # FastAPI >= 0.16x: included routers are branches, flattened by this
    from fastapi.routing import iter_route_contexts as _iter_contexts

    iter_route_contexts: Callable[[Any], Iterable[Any]] | None = _iter_contexts
except ImportError:  # pragma: no cover - older FastAPI
    iter_route_contexts = None

from gateway.api.auth_failures import AuthFailures, failures_of, throttled_problem
from gateway.api.problems import ApiProblem, Problem, problem_type
from gateway.service.principal import Principal
from gateway.service.roles import Role

__all__ = [
    "ANONYMOUS",
    "AuthConfig",
    "EffectiveRoute",
    "Principal",
    "RoleRequirement",
    "RouteRole",
    "TokenBook",
    "TokenEntry",
    "api_routes",
    "auth_of_scope",
    "authenticate_websocket",
    "bearer_of_headers",
    "hash_token",
    "install_security",
    "is_loopback",
    "new_token",
    "principal_of",
    "require",
    "route_roles",
]

#: the name no-auth mode gives every caller (the audit log records it)
ANONYMOUS = "anonymous"
_REALM = 'Bearer realm="rc233-gateway"'


def hash_token(token: str) -> str:
    """The SHA-256 hex digest of ``token``: what the configuration stores."""
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


def new_token() -> str:
    """A fresh random token (256 bits, URL-safe), for ``rc233-gateway token``."""
    return secrets.token_urlsafe(32)


def is_loopback(host: str) -> bool:
    """True when ``host`` (an address or ``localhost``) is only reachable from this machine."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


class TokenLike(Protocol):
    """What ``TokenBook.from_settings`` reads of a token (config ``TokenSettings``)."""

    @property
    def name(self) -> str:
        """The token's name (recorded in the audit log)."""

    @property
    def role(self) -> Role:
        """The role it grants."""

    @property
    def sha256(self) -> str:
        """The hex digest of the token."""


@dataclass(frozen=True)
class TokenEntry:
    """One known token: its name, role and digest."""

    name: str
    role: Role
    sha256: str


class TokenBook:
    """The known tokens, looked up by digest in constant time per entry."""

    def __init__(self, entries: Iterable[TokenEntry] = ()) -> None:
        self._entries = tuple(entries)

    @classmethod
    def from_settings(cls, tokens: Iterable[TokenLike]) -> TokenBook:
        """The book of the configuration's ``security.tokens``."""
        return cls(TokenEntry(t.name, Role(t.role), t.sha256.lower()) for t in tokens)

    def __len__(self) -> int:
        return len(self._entries)

    def __iter__(self) -> Iterator[TokenEntry]:
        return iter(self._entries)

    def lookup(self, token: str) -> TokenEntry | None:
        """The entry of ``token``, None when unknown. Every entry is compared (no early exit),
        each with ``hmac.compare_digest``, so timing tells nothing of which digits matched."""
        digest = hash_token(token).encode("ascii")
        found: TokenEntry | None = None
        for entry in self._entries:
            if hmac.compare_digest(digest, entry.sha256.encode("ascii")) and found is None:
                found = entry
        return found

    def principal(self, token: str, client: str) -> Principal | None:
        """Who ``token`` names, asking from ``client`` (None: unknown); an ``Identify`` of
        every face."""
        entry = self.lookup(token)
        return None if entry is None else Principal(entry.name, entry.role, client)


@dataclass(frozen=True)
class AuthConfig:
    """How the API authenticates: the token book, or no-auth mode (everyone is admin)."""

    book: TokenBook = field(default_factory=TokenBook)
    no_auth: bool = False

    @classmethod
    def decide(
        cls,
        host: str,
        tokens: Iterable[TokenLike] = (),
        *,
        no_auth: bool = False,
    ) -> AuthConfig:
        """The mode of ``serve``: the tokens, or open with ``--no-auth``, which is allowed on
        loopback only (ValueError otherwise). Nothing else turns authentication off."""
        book = TokenBook.from_settings(tokens)
        if no_auth and not is_loopback(host):
            raise ValueError(f"--no-auth is only allowed when bound to loopback, not {host!r}")
        return cls(book, no_auth=no_auth)

    def authenticate(self, token: str | None, client: str) -> Principal | None:
        """The principal of ``token`` (None: missing or unknown); anyone in no-auth mode."""
        if self.no_auth:
            return Principal(ANONYMOUS, Role.ADMIN, client)
        if not token:
            return None
        return self.book.principal(token, client)


def install_security(app: FastAPI, auth: AuthConfig, failures: AuthFailures | None = None) -> None:
    """Make ``auth`` the mode of ``app``'s ``require`` dependencies; ``failures`` counts
    and records failed authentications (back-off per client address)."""
    app.state.auth = auth
    app.state.auth_failures = failures


def _auth_of(connection: HTTPConnection) -> AuthConfig:
    return auth_of_scope(connection.scope)


def auth_of_scope(scope: Scope) -> AuthConfig:
    """The mode of the app serving ``scope`` (``install_security``)."""
    app = scope.get("app")
    auth = getattr(getattr(app, "state", None), "auth", None)
    # Fail closed: an app nobody configured knows no token.
    return auth if isinstance(auth, AuthConfig) else AuthConfig()


def _client(connection: HTTPConnection) -> str:
    return connection.client.host if connection.client else "unknown"


_bearer = HTTPBearer(
    auto_error=False,
    scheme_name="bearer",
    description="An API token of the configuration (security.tokens); roles viewer, "
    "operator, admin.",
)


class RoleRequirement:
    """The dependency ``require(role)`` returns: the caller's ``Principal`` if it has ``role``."""

    def __init__(self, role: Role) -> None:
        self.role = role

    def __repr__(self) -> str:
        return f"require(Role.{self.role.name})"

    async def __call__(
        self,
        request: Request,
        credentials: Annotated[HTTPAuthorizationCredentials | None, Security(_bearer)],
    ) -> Principal:
        """Authenticate ``request`` and check its role."""
        auth = _auth_of(request)
        token = credentials.credentials if credentials is not None else None
        client = _client(request)
        failures = None if auth.no_auth else failures_of(request.scope)
        what = f"{request.method} {request.scope['path']}"  # only for a record: cheap
        if failures is not None:
            wait = failures.retry_after(client)
            if wait is not None:
                # Refused before the token is looked at: a right guess looks like a wrong one.
                request.state.auth_failed = True  # recorded by AuthFailures, not per request
                failures.throttled(client, what)
                raise ApiProblem(throttled_problem(wait), {"Retry-After": str(math.ceil(wait))})
        principal = auth.authenticate(token, client)
        if principal is None:
            if token is None:
                detail, header = "this request needs a bearer token (Authorization: Bearer)", _REALM
            else:
                detail, header = "the bearer token is not known", f'{_REALM}, error="invalid_token"'
            if failures is not None:
                request.state.auth_failed = True
                failures.failed(client, what, guessed=token is not None)
            problem = Problem(
                type=problem_type("unauthorized"), title="Unauthorized", status=401, detail=detail
            )
            raise ApiProblem(problem, {"WWW-Authenticate": header})
        if failures is not None:
            failures.succeeded(client)
        request.state.principal = principal  # the audit log records who it was
        if not principal.role.allows(self.role):
            problem = Problem(
                type=problem_type("forbidden"),
                title="Forbidden",
                status=403,
                detail=f"this request needs the {self.role} role; the token "
                f"{principal.name!r} has the {principal.role} role",
                required_role=str(self.role),
            )
            raise ApiProblem(problem)
        return principal


@cache
def require(role: Role) -> RoleRequirement:
    """The dependency of a route that needs ``role``: ``Depends(require(Role.OPERATOR))``."""
    return RoleRequirement(role)


def _bearer_of(connection: HTTPConnection) -> str | None:
    return bearer_of_headers(connection.scope)


def bearer_of_headers(scope: Scope) -> str | None:
    """The bearer token of the first ``Authorization`` header of ``scope``, by the rule of
    FastAPI's ``HTTPBearer`` (the scheme up to the first space, any case; the rest stripped,
    not empty); None without one. Read straight from the raw headers: the cached read asks
    it of every request (``gateway.api.routes.axis_read_path``)."""
    for name, value in scope.get("headers", ()):
        if name.lower() == b"authorization":
            scheme, _, credentials = value.decode("latin-1").partition(" ")
            token = credentials.strip()
            return token if scheme.lower() == "bearer" and token else None
    return None


def principal_of(scope: Scope) -> Principal | None:
    """Who sent the request of ``scope`` by its ``Authorization`` header (None: no or an
    unknown token), for answers given before any route authenticated it (the audit log)."""
    connection = HTTPConnection(scope)
    if "app" not in scope:
        return None
    return _auth_of(connection).authenticate(_bearer_of(connection), _client(connection))


def authenticate_websocket(ws: WebSocket, auth: AuthConfig | TokenBook) -> Principal | None:
    """The principal of a WebSocket handshake: ``Authorization: Bearer``, or ``?token=`` for
    browsers (which cannot set headers on a WebSocket). None: missing or unknown token.
    A bare ``TokenBook`` means tokens are required."""
    config = auth if isinstance(auth, AuthConfig) else AuthConfig(auth)
    token = _bearer_of(ws) or ws.query_params.get("token")
    principal = config.authenticate(token, _client(ws))
    if principal is not None:
        ws.state.principal = principal
    return principal


@dataclass(frozen=True)
class RouteRole:
    """A route and the role its dependencies require (None: open to anyone)."""

    path: str
    methods: frozenset[str]
    name: str
    role: Role | None

    @property
    def mutating(self) -> bool:
        """True for POST, PUT, PATCH and DELETE."""
        return bool(self.methods & {"POST", "PUT", "PATCH", "DELETE"})


def _requirements(dependant: Any) -> Iterator[Role]:
    call = getattr(dependant, "call", None)
    if isinstance(call, RoleRequirement):
        yield call.role
    for sub in getattr(dependant, "dependencies", ()):
        yield from _requirements(sub)


@dataclass(frozen=True)
class EffectiveRoute:
    """A route as the app serves it: its full path template (prefixes of included routers
    applied), methods, and the dependency tree with the routers' dependencies."""

    original: BaseRoute
    path: str
    methods: frozenset[str]
    name: str
    dependant: Any
    path_regex: re.Pattern[str] | None


def api_routes(app: FastAPI) -> list[EffectiveRoute]:
    """Every route of ``app`` as served. FastAPI >= 0.16x keeps included routers as
    branches (``app.routes`` holds an ``_IncludedRouter``; ``scope["route"]`` is the route as
    declared, without its prefix); ``iter_route_contexts`` is what its OpenAPI reads."""
    # Older FastAPI copies included routes into app.routes with their prefix.
    flat = iter_route_contexts
    contexts: Iterable[Any] = flat(app.routes) if flat is not None else app.routes
    out: list[EffectiveRoute] = []
    for ctx in contexts:
        original = getattr(ctx, "original_route", ctx)
        path = getattr(ctx, "path_format", None) or getattr(ctx, "path", None)
        if not isinstance(path, str):
            continue
        out.append(
            EffectiveRoute(
                original=original,
                path=path,
                methods=frozenset(getattr(ctx, "methods", None) or ()),
                name=str(getattr(ctx, "name", "") or ""),
                dependant=getattr(ctx, "dependant", None),
                path_regex=getattr(ctx, "path_regex", None),
            )
        )
    return out


def route_roles(app: FastAPI) -> list[RouteRole]:
    """Every HTTP API route of ``app`` (full path) with the highest role its dependencies
    require, for the role enumeration test (WebSocket routes authenticate in their handler,
    and the docs routes are FastAPI's own: neither is listed)."""
    out: list[RouteRole] = []
    for route in api_routes(app):
        if not isinstance(route.original, APIRoute):
            continue
        roles = list(_requirements(route.dependant))
        role = max(roles, key=lambda r: r.rank) if roles else None
        out.append(RouteRole(route.path, route.methods, route.name, role))
    return out
