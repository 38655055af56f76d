"""Bearer tokens and roles, on a small app of the test's own."""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Annotated, Any

import httpx
import pytest
from fastapi import APIRouter, Depends, FastAPI, WebSocket

from gateway.api.problem_docs import install_problem_docs
from gateway.api.problems import install_problem_handlers
from gateway.api.security import (
    AuthConfig,
    Principal,
    TokenBook,
    TokenEntry,
    authenticate_websocket,
    hash_token,
    install_security,
    is_loopback,
    new_token,
    require,
    route_roles,
)
from gateway.service.config import TokenSettings
from gateway.service.roles import Role

PROBLEM = "application/problem+json"
TOKENS = {"vera": "viewer-secret", "otto": "operator-secret", "ada": "admin-secret"}
ROLES = {"vera": Role.VIEWER, "otto": Role.OPERATOR, "ada": Role.ADMIN}


def book() -> TokenBook:
    return TokenBook.from_settings(
        TokenSettings(name=name, role=ROLES[name], sha256=hash_token(token))
        for name, token in TOKENS.items()
    )


def build_app(auth: AuthConfig) -> FastAPI:
    app = FastAPI()
    install_problem_handlers(app)
    install_problem_docs(app)
    install_security(app, auth)

    def who(p: Principal) -> dict[str, Any]:
        return {"name": p.name, "role": str(p.role), "client": p.client}

    @app.get("/axes")
    async def read(p: Annotated[Principal, Depends(require(Role.VIEWER))]) -> dict[str, Any]:
        return who(p)

    @app.post("/axes/{ident}/move")
    async def move(
        ident: str, p: Annotated[Principal, Depends(require(Role.OPERATOR))]
    ) -> dict[str, Any]:
        return who(p)

    admin = APIRouter(dependencies=[Depends(require(Role.ADMIN))])

    @admin.post("/loops/{loop}/raw")
    async def raw(loop: str) -> dict[str, str]:
        return {"loop": loop}

    app.include_router(admin)

    @app.get("/open")
    async def open_route() -> dict[str, str]:
        return {"open": "yes"}

    return app


@pytest.fixture
async def client() -> AsyncIterator[httpx.AsyncClient]:
    transport = httpx.ASGITransport(app=build_app(AuthConfig(book())), client=("10.0.0.7", 999))
    async with httpx.AsyncClient(transport=transport, base_url="http://localhost") as c:
        yield c


def bearer(name: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {TOKENS[name]}"}


def test_hash_token_is_sha256_hex():
    # FIPS 180-2 example: SHA-256("abc")
    assert hash_token("abc") == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    token = new_token()
    assert len(token) >= 43 and token != new_token()


async def test_no_token_is_401_with_a_bearer_challenge(client: httpx.AsyncClient):
    r = await client.get("/axes")
    assert r.status_code == 401
    assert r.headers["content-type"] == PROBLEM
    assert r.headers["www-authenticate"].startswith("Bearer")
    assert "invalid_token" not in r.headers["www-authenticate"]
    assert r.json()["status"] == 401


@pytest.mark.parametrize(
    "header",
    ["Bearer not-a-known-token", "Bearer viewer-secretX", "Basic dmVyYTp2aWV3ZXItc2VjcmV0"],
)
async def test_an_unknown_token_or_another_scheme_is_401(client: httpx.AsyncClient, header: str):
    r = await client.get("/axes", headers={"Authorization": header})
    assert r.status_code == 401
    assert r.headers["www-authenticate"].startswith("Bearer")
    assert r.headers["content-type"] == PROBLEM


async def test_each_token_acts_as_its_name_and_role(client: httpx.AsyncClient):
    r = await client.get("/axes", headers=bearer("vera"))
    assert r.status_code == 200
    assert r.json() == {"name": "vera", "role": "viewer", "client": "10.0.0.7"}
    r = await client.post("/axes/x/move", headers=bearer("otto"))
    assert r.json()["name"] == "otto"


@pytest.mark.parametrize(
    ("name", "path", "needed"),
    [("vera", "/axes/x/move", "operator"), ("vera", "/loops/main/raw", "admin"),
     ("otto", "/loops/main/raw", "admin")],
)  # fmt: skip
async def test_a_weaker_role_is_403_naming_the_role_needed(
    client: httpx.AsyncClient, name: str, path: str, needed: str
):
    r = await client.post(path, headers=bearer(name))
    assert r.status_code == 403
    assert r.headers["content-type"] == PROBLEM
    body = r.json()
    assert body["required_role"] == needed
    assert f"needs the {needed} role" in body["detail"]
    assert str(ROLES[name]) in body["detail"]


@pytest.mark.parametrize("name", ["otto", "ada"])
async def test_a_higher_role_may_do_what_a_lower_may(client: httpx.AsyncClient, name: str):
    assert (await client.get("/axes", headers=bearer(name))).status_code == 200
    assert (await client.post("/axes/a/move", headers=bearer(name))).status_code == 200


async def test_admin_reaches_admin_routes_and_open_routes_need_nothing(
    client: httpx.AsyncClient,
):
    assert (await client.post("/loops/main/raw", headers=bearer("ada"))).json() == {"loop": "main"}
    assert (await client.get("/open")).status_code == 200


async def test_no_auth_mode_makes_everyone_an_anonymous_admin():
    app = build_app(AuthConfig(book(), no_auth=True))
    transport = httpx.ASGITransport(app=app, client=("127.0.0.1", 5))
    async with httpx.AsyncClient(transport=transport, base_url="http://localhost") as c:
        r = await c.post("/axes/x/move")
        assert r.json() == {"name": "anonymous", "role": "admin", "client": "127.0.0.1"}
        assert (await c.post("/loops/l/raw", headers={"Authorization": "Bearer junk"})).is_success


async def test_an_app_without_install_security_refuses_everyone():
    app = FastAPI()
    install_problem_handlers(app)

    @app.get("/axes")
    async def read(p: Annotated[Principal, Depends(require(Role.VIEWER))]) -> str:
        return p.name

    transport = httpx.ASGITransport(app=app)
    async with httpx.AsyncClient(transport=transport, base_url="http://localhost") as c:
        assert (await c.get("/axes", headers=bearer("ada"))).status_code == 401


def test_decide_no_auth_only_on_loopback():
    tokens = [TokenSettings(name="ada", role=Role.ADMIN, sha256=hash_token("x"))]
    with pytest.raises(ValueError, match="loopback"):
        AuthConfig.decide("0.0.0.0", no_auth=True)
    assert AuthConfig.decide("127.0.0.1", tokens, no_auth=True).no_auth
    assert AuthConfig.decide("::1", no_auth=True).no_auth
    # One rule: nothing but --no-auth turns authentication off (no tokens: nobody gets in)
    assert not AuthConfig.decide("127.0.0.1").no_auth
    assert not AuthConfig.decide("127.0.0.1", tokens).no_auth
    assert not AuthConfig.decide("localhost").no_auth
    assert [is_loopback(h) for h in ("localhost", "127.0.0.2", "[::1]", "192.168.1.2", "host")] == [
        True, True, True, False, False
    ]  # fmt: skip


def test_the_book_knows_tokens_by_digest_only():
    entries = book()
    assert entries.lookup("admin-secret") == TokenEntry(
        "ada", Role.ADMIN, hash_token("admin-secret")
    )
    assert entries.lookup("admin-secre") is None
    assert entries.lookup("") is None
    assert all("secret" not in e.sha256 for e in entries)


def _websocket(headers: dict[str, str], query: str = "") -> WebSocket:
    scope = {
        "type": "websocket",
        "path": "/api/v1/ws",
        "headers": [(k.lower().encode(), v.encode()) for k, v in headers.items()],
        "query_string": query.encode(),
        "client": ("192.0.2.1", 1234),
    }

    async def receive() -> Any:
        raise AssertionError("not used")

    async def send(message: Any) -> None:
        raise AssertionError("not used")

    return WebSocket(scope, receive, send)


def test_websocket_token_from_the_header_or_the_query():
    auth = AuthConfig(book())
    by_header = authenticate_websocket(_websocket(bearer("otto")), auth)
    assert by_header == Principal("otto", Role.OPERATOR, "192.0.2.1")
    by_query = authenticate_websocket(_websocket({}, "token=viewer-secret"), auth)
    assert by_query == Principal("vera", Role.VIEWER, "192.0.2.1")
    assert authenticate_websocket(_websocket({}), auth) is None
    assert authenticate_websocket(_websocket({}, "token=nope"), auth) is None
    # a bare book requires tokens; no-auth mode lets anyone in as admin
    assert authenticate_websocket(_websocket({}), book()) is None
    anyone = authenticate_websocket(_websocket({}), AuthConfig(book(), no_auth=True))
    assert anyone == Principal("anonymous", Role.ADMIN, "192.0.2.1")


def test_route_roles_lists_each_route_with_the_role_it_needs():
    roles = {(r.path, m): r for r in route_roles(build_app(AuthConfig())) for m in r.methods}
    assert roles[("/axes", "GET")].role is Role.VIEWER
    assert roles[("/axes/{ident}/move", "POST")].role is Role.OPERATOR
    assert roles[("/loops/{loop}/raw", "POST")].role is Role.ADMIN  # from the router
    assert roles[("/open", "GET")].role is None
    assert roles[("/axes/{ident}/move", "POST")].mutating
    assert not roles[("/axes", "GET")].mutating


def test_openapi_lists_401_and_403_on_secured_routes_only():
    doc = build_app(AuthConfig()).openapi()
    move = doc["paths"]["/axes/{ident}/move"]["post"]
    assert {"401", "403"} <= set(move["responses"])
    assert move["security"] == [{"bearer": []}]
    assert "401" not in doc["paths"]["/open"]["get"]["responses"]
