"""The open mode (``serve --simulate --no-auth``, what ``make run`` starts) attacked as a web
page would: through a real ``serve`` process, since the Host and Origin a browser sends, the
WebSocket upgrade, uvicorn's own log lines and its headers are the transport's.
"""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

import httpx
import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import InvalidStatus

from tests.support.serve_process import Served, serve

EVIL = "http://evil.example"
JSON = {"Content-Type": "application/json"}


async def _operations(client: httpx.AsyncClient) -> list[Any]:
    response = await client.get("/api/v1/operations")
    assert response.status_code == 200, response.text
    ops: list[Any] = response.json()
    return ops


async def _raw_upgrade(served: Served, host: str, origin: str | None) -> str:
    """The status line the server answers a WebSocket upgrade naming ``host``."""
    reader, writer = await asyncio.open_connection("127.0.0.1", served.port)
    lines = [
        "GET /api/v1/ws HTTP/1.1",
        f"Host: {host}",
        "Upgrade: websocket",
        "Connection: Upgrade",
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==",
        "Sec-WebSocket-Version: 13",
    ]
    if origin is not None:
        lines.append(f"Origin: {origin}")
    writer.write(("\r\n".join(lines) + "\r\n\r\n").encode())
    await writer.drain()
    try:
        status = await asyncio.wait_for(reader.readline(), 10)
    finally:
        writer.close()
    return status.decode().strip()


async def test_a_page_of_another_site_cannot_act_in_the_open_mode(tmp_path: Path) -> None:
    async with serve(tmp_path) as served, httpx.AsyncClient(base_url=served.url) as client:
        tries = [
            ("POST", "/api/v1/axes/x/home", {"Origin": EVIL, **JSON}),
            ("POST", "/api/v1/controllers/handler/program/run", {"Origin": EVIL, **JSON}),
            ("POST", "/api/v1/controllers/handler/eeprom/erase", {"Origin": EVIL, **JSON}),
            ("POST", "/api/v1/loops/sim/stop", {"Origin": EVIL, **JSON}),
            ("POST", "/api/v1/axes/theta/lease", {"Sec-Fetch-Site": "cross-site", **JSON}),
            ("POST", "/api/v1/axes/x/home", {"Origin": "null", **JSON}),
            # another port of the same machine is another site (a local dev server)
            ("POST", "/api/v1/axes/x/home", {"Origin": "http://127.0.0.1:1", **JSON}),
        ]
        for method, path, headers in tries:
            refused = await client.request(method, path, headers=headers)
            assert refused.status_code == 403, (path, headers, refused.text)
            assert refused.headers["content-type"] == "application/problem+json"
            problem = refused.json()
            assert problem["field"] == "header.origin", problem
        # What a browser sends across sites without asking first: no type, a form, text.
        for headers in ({}, {"Content-Type": "text/plain"},
                        {"Content-Type": "application/x-www-form-urlencoded"}):  # fmt: skip
            refused = await client.post("/api/v1/axes/x/home", headers=headers, content=b"")
            assert refused.status_code == 415, (headers, refused.text)
            assert refused.json()["field"] == "header.content-type"
            assert "with a body or without" in refused.json()["rule"]
        assert await _operations(client) == []  # nothing moved
        lease = await client.get("/api/v1/axes/theta/lease")
        assert lease.status_code == 200 and lease.json()["holder"] is None, lease.text
        # The gateway's own page (same origin) still acts.
        own = {"Origin": served.url, "Sec-Fetch-Site": "same-origin", **JSON}
        stop = await client.post("/api/v1/axes/x/stop", headers=own)
        assert stop.status_code == 200, stop.text


async def test_a_rebound_name_is_refused_for_every_route(tmp_path: Path) -> None:
    async with serve(tmp_path) as served, httpx.AsyncClient(base_url=served.url) as client:
        evil_host = {"Host": f"evil.example:{served.port}"}
        for method, path in [("GET", "/api/v1/axes"), ("GET", "/"), ("GET", "/healthz"),
                             ("POST", "/api/v1/axes/gripper/home")]:  # fmt: skip
            refused = await client.request(method, path, headers={**evil_host, **JSON})
            assert refused.status_code == 421, (path, refused.text)
            assert refused.json()["field"] == "header.host"
        assert await _operations(client) == []
        for host in (f"localhost:{served.port}", f"127.0.0.1:{served.port}", "[::1]"):
            ok = await client.get("/api/v1/axes", headers={"Host": host})
            assert ok.status_code == 200, (host, ok.text)


async def test_a_websocket_from_another_site_or_host_is_refused_before_the_feed(
    tmp_path: Path,
) -> None:
    async with serve(tmp_path) as served:
        ws_url = served.url.replace("http", "ws") + "/api/v1/ws"
        with pytest.raises(InvalidStatus) as refused:
            async with connect(ws_url, origin=EVIL, open_timeout=10):  # type: ignore[arg-type]
                pass
        assert refused.value.response.status_code == 403
        assert (await _raw_upgrade(served, f"evil.example:{served.port}", None)).startswith(
            "HTTP/1.1 403"
        )
        own = await _raw_upgrade(served, f"127.0.0.1:{served.port}", served.url)
        assert own.startswith("HTTP/1.1 101"), own
        async with connect(ws_url, origin=served.url, open_timeout=10) as ws:  # type: ignore[arg-type]
            await ws.send('{"type": "ping", "id": 1}')
            assert '"pong"' in str(await asyncio.wait_for(ws.recv(), 10))


async def test_answers_name_no_server_and_odd_methods_are_one_series(tmp_path: Path) -> None:
    async with serve(tmp_path) as served, httpx.AsyncClient(base_url=served.url) as client:
        answer = await client.get("/healthz")
        assert "server" not in answer.headers, answer.headers
        odd = ["PROPFIND", "PROPPATCH", "MKCOL", "COPY", "MOVE", "LOCK", "UNLOCK", "SEARCH"]
        for method in odd:
            await client.request(method, "/api/v1/axes")
        text = (await client.get("/metrics")).text
        lines = [line for line in text.splitlines() if line.startswith("rc233_http_requests_total")]
        assert not any(m in line for line in lines for m in odd), lines
        assert any('method="other"' in line for line in lines), lines
