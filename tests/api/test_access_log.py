"""The access log: a line for every request that changes something or fails (INFO), reads
that succeeded at DEBUG only, tokens masked."""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator

import pytest

from tests.support.sim_app import Api, running_app


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app() as running:
        yield running


def _lines(caplog: pytest.LogCaptureFixture) -> list[tuple[int, str]]:
    return [(r.levelno, r.getMessage()) for r in caplog.records if r.name == "gateway.access"]


async def test_reads_at_debug_changes_and_failures_at_info(
    api: Api, caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.INFO, logger="gateway.access"):
        assert (await api.client.get("/axes/x")).status_code == 200
        assert (await api.client.get("/axes/nowhere")).status_code == 404
        stop = await api.client.post("/axes/x/stop", json={"mode": "immediate"})
        assert stop.status_code == 200, stop.text
    assert _lines(caplog) == [
        (logging.INFO, '127.0.0.1:123 - "GET /api/v1/axes/nowhere HTTP/1.1" 404'),
        (logging.INFO, '127.0.0.1:123 - "POST /api/v1/axes/x/stop HTTP/1.1" 200'),
    ]
    caplog.clear()
    with caplog.at_level(logging.DEBUG, logger="gateway.access"):
        assert (await api.client.get("/axes/x?token=s3cr3t")).status_code == 200
    assert _lines(caplog) == [
        (logging.DEBUG, '127.0.0.1:123 - "GET /api/v1/axes/x?token=*** HTTP/1.1" 200')
    ]
