"""The host, origin and JSON rules in the app: what a refused request leaves on the wire
(nothing), and the settings that widen them (``allowed_hosts``, ``cors_origins``)."""

from __future__ import annotations

import pytest

from gateway.api.middleware.request_guard import HostRule, RequestGuard
from gateway.service.runtime.simulated import simulated_config
from tests.support.sim_app import running_app

EVIL = "http://evil.example"
JSON = {"Content-Type": "application/json"}


async def test_refused_acts_put_nothing_on_the_wire() -> None:
    async with running_app(("1",)) as api:
        mark = api.mark()
        refused = [
            await api.client.post("/axes/x/home", headers={"Origin": EVIL, **JSON}),
            await api.client.post("/axes/x/home", headers={"Host": "evil.example", **JSON}),
            await api.client.post("/axes/x/home", headers={"Content-Type": "text/plain"}),
            await api.client.post(
                "/axes/x/home",
                headers={"Content-Type": "application/x-www-form-urlencoded"},
                content=b"method=0",
            ),
            await api.client.put("/axes/x/speed", headers={"Origin": EVIL, **JSON}, json={}),
            await api.client.delete("/axes/x/lease", headers={"Content-Type": ""}),
        ]
        assert [r.status_code for r in refused] == [403, 421, 415, 415, 403, 415]
        assert all(r.headers["content-type"] == "application/problem+json" for r in refused)
        # Nothing but the poller's reads went out: no home (``0``), no speed, no lease taken.
        sent = api.heard("1", since=mark)
        assert not [c for c in sent if c.startswith(("0", "F", "D", "S"))], sent
        own = await api.client.post("/axes/x/stop", headers={"Origin": "http://localhost", **JSON})
        assert own.status_code == 200, own.text


async def test_allowed_hosts_and_cors_origins_widen_the_rules() -> None:
    config = simulated_config(("1",))
    security = config.security.model_copy(
        update={"allowed_hosts": ["gw.plant.example"], "cors_origins": ["https://mes.example"]}
    )
    config = config.model_copy(update={"security": security})
    async with running_app(("1",), config=config) as api:
        named = await api.client.get("/axes", headers={"Host": "GW.plant.example:8443"})
        assert named.status_code == 200, named.text
        assert (await api.client.get("/axes", headers={"Host": "other.example"})).status_code == 421
        mes = await api.client.post(
            "/axes/x/stop",
            headers={"Origin": "https://mes.example", "Sec-Fetch-Site": "cross-site", **JSON},
        )
        assert mes.status_code == 200, mes.text
        assert mes.headers["access-control-allow-origin"] == "https://mes.example"
        assert (
            await api.client.post("/axes/x/stop", headers={"Origin": EVIL, **JSON})
        ).status_code == 403


@pytest.mark.parametrize(
    ("host", "allowed"),
    [
        ("localhost", True), ("LOCALHOST:8233", True), ("app.localhost", True),
        ("127.0.0.1:80", True), ("127.9.9.9", True), ("[::1]:8233", True), ("localhost.", True),
        ("evil.example", False), ("localhost.evil.example", False), ("10.0.0.1", False),
        ("", False), ("[::2]", False), ("0.0.0.0", False),
    ],
)  # fmt: skip
def test_the_open_mode_names_only_loopback(host: str, allowed: bool) -> None:
    assert HostRule().allows(host) is allowed


def test_allowed_hosts_from_the_file_are_checked() -> None:
    from gateway.service.config import SecuritySettings

    with pytest.raises(ValueError, match="allowed_hosts"):
        SecuritySettings(allowed_hosts=["http://gw.example/"])
    assert SecuritySettings(allowed_hosts=["gw.example", "[fe80::1]", "*"]).allowed_hosts


@pytest.mark.parametrize(
    ("host", "status"),
    [("192.0.2.7:8233", None), ("192.0.2.7", None), ("192.0.2.8:8233", 421),
     ("gw.example", 421), ("", 400)],
)  # fmt: skip
def test_the_address_a_connection_came_in_on_names_the_gateway(
    host: str, status: int | None
) -> None:
    # A gateway bound to every address, reached as http://192.0.2.7:8233 (no name to rebind).
    guard = RequestGuard(lambda *_: None)  # type: ignore[arg-type, return-value]
    scope = {"type": "http", "method": "GET", "server": ("192.0.2.7", 8233),
             "headers": [(b"host", host.encode())] if host else []}  # fmt: skip
    refusal = guard.refusal(scope)
    assert (refusal.status if refusal else None) == status


@pytest.mark.parametrize(
    ("host", "origin", "site", "status"),
    [
        ("localhost:8233", "http://localhost:8233", "same-origin", None),
        ("127.0.0.1:8233", "http://127.0.0.1:8233", None, None),
        ("[::1]:8233", "http://[::1]:8233", None, None),
        ("localhost:8233", "http://localhost:3000", "same-site", 403),  # a local dev server
        ("localhost:8233", "http://127.0.0.1:8233", None, 403),  # another name: another site
        ("localhost:8233", "null", None, 403),
        ("localhost:8233", None, "cross-site", 403),
        ("localhost:8233", None, "none", None),  # typed by the user
        ("localhost:8233", None, None, None),  # not a browser
        # Behind a TLS proxy passing the client's Host (no port): the page is on 443.
        ("gw.plant.example", "https://gw.plant.example", "same-origin", None),
        ("gw.plant.example", "https://gw.plant.example:8443", None, 403),
    ],
)  # fmt: skip
def test_acts_come_from_the_gateways_own_pages(
    host: str, origin: str | None, site: str | None, status: int | None
) -> None:
    guard = RequestGuard(lambda *_: None, allowed_hosts=["gw.plant.example"])  # type: ignore[arg-type, return-value]
    headers = [(b"host", host.encode())]
    headers += [(b"origin", origin.encode())] if origin else []
    headers += [(b"sec-fetch-site", site.encode())] if site else []
    scope = {"type": "http", "method": "POST", "scheme": "http", "headers": headers}
    refusal = guard.refusal(scope)
    assert (refusal.status if refusal else None) == status, refusal
    assert guard.refusal({**scope, "method": "GET"}) is None  # reads are not concerned
