"""schemathesis against openapi.json: no 5xx, no response that breaks the schema.

The real app runs on a real uvicorn server (a thread with its own event loop) on an
in-process simulated loop; schemathesis generates requests for every operation of the
published document and checks each response: never a server error, status codes, content
types and bodies as documented.
"""

from __future__ import annotations

import asyncio
import contextlib
import re
import socket
import threading
from collections.abc import Iterator

import pytest
import schemathesis
import uvicorn
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    response_schema_conformance,
    status_code_conformance,
)

from gateway.api.app import create_app
from gateway.api.security import AuthConfig
from gateway.cli.documents import documents
from gateway.cli.serve import sim_line
from gateway.compose import compose
from gateway.service.runtime.runtime import Runtime
from gateway.service.runtime.simulated import SIM_LOOP, simulated_config
from gateway.sim.cli import build_loop
from gateway.sim.clock import SimClock

SCALE = 100.0
SCHEMA = schemathesis.openapi.from_dict(documents()["openapi.json"])
CHECKS = [
    not_a_server_error,
    status_code_conformance,
    content_type_conformance,
    response_schema_conformance,
]


class ServerThread(threading.Thread):
    """uvicorn serving the app on a simulated loop, in a thread of its own."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self.port = port
        self.server: uvicorn.Server | None = None
        self.started = threading.Event()

    def run(self) -> None:
        asyncio.run(self._serve())

    async def _serve(self) -> None:
        sim = build_loop(["1", "2", "3"], clock=SimClock(SCALE))
        gateway = Runtime(
            simulated_config(),
            transports={SIM_LOOP: sim_line(sim)},
            time_scale=SCALE,
        )
        app = create_app(compose(gateway), auth=AuthConfig(no_auth=True))
        config = uvicorn.Config(app, host="127.0.0.1", port=self.port, log_level="warning")
        self.server = uvicorn.Server(config)
        watcher = asyncio.create_task(self._announce())
        try:
            await self.server.serve()
        finally:
            watcher.cancel()
            sim.close()

    async def _announce(self) -> None:
        assert self.server is not None
        while not self.server.started:
            await asyncio.sleep(0.01)  # uvicorn offers no event for "listening"
        self.started.set()


@pytest.fixture(scope="module")
def base_url() -> Iterator[str]:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    thread = ServerThread(port)
    thread.start()
    assert thread.started.wait(30), "the server did not start"
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        assert thread.server is not None
        thread.server.should_exit = True
        thread.join(30)
        with contextlib.suppress(Exception):
            assert not thread.is_alive()


@pytest.mark.contract
@SCHEMA.parametrize()
@settings(
    max_examples=6,
    deadline=None,
    suppress_health_check=list(HealthCheck),
    derandomize=True,
)
def test_no_server_error_and_every_response_as_documented(case, base_url: str) -> None:  # type: ignore[no-untyped-def]
    if not _valid_http_headers(case.headers):
        # Not an HTTP request: uvicorn's parser refuses it (400, its own text/plain) before
        # the app sees it. Which cases hypothesis draws shifts with any change of the code.
        response = case.call(base_url=base_url, timeout=60)
        assert response.status_code == 400, response.text
        return
    headers = None
    declared = {name.lower() for name in (case.headers or {})}
    if case.method.upper() in ("POST", "PUT", "PATCH", "DELETE") and "content-type" not in declared:
        # As the dashboard does: every request that acts is declared JSON, bodyless too.
        headers = {"Content-Type": "application/json"}
    case.call_and_validate(base_url=base_url, checks=CHECKS, timeout=60, headers=headers)


#: A header name is a token (RFC 9110 §5.1, §5.6.2).
_TOKEN = re.compile(r"[!#$%&'*+.^_`|~0-9A-Za-z-]+")


def _valid_http_headers(headers: dict[str, str] | None) -> bool:
    """True when every generated header can be sent in an HTTP/1.1 request: its name is a
    token, and a Content-Length is a number."""
    for name, value in (headers or {}).items():
        if not _TOKEN.fullmatch(name):
            return False
        if name.lower() == "content-length" and not str(value).strip().isdigit():
            return False
    return True
