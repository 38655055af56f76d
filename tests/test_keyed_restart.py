"""A keyed request that is not a motion never acts twice across a restart: a program run
(``POST /controllers/{id}/program/run``, §10 G) whose gateway is killed after ``G`` went out
and before it answered is, on the retry with the same key, an ``idempotency-outcome-unknown``
problem, and ``G`` is heard once.

Real processes: ``rc233-gateway sim --tcp`` stays up while ``serve`` is SIGKILLed and started
again on the same state directory (``tests.support.restart_rig``).
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from pathlib import Path

import httpx
import pytest

from tests.support.restart_rig import WAIT, RestartRig

SCALE = 1.0
#: Output 0 ON, then a jump to itself: runs until stopped (§12 /J).
ENDLESS = "/D01B/J-1/END"
PROGRAM = "/controllers/stage/program"
RUN = "$1G"  # §10 G: run from the start
#: Every reply leaves this many seconds late while the run is in flight: the gateway is
#: killed between the line hearing G and its answer. Well inside the reply time-out the
#: configuration allows (host_latency below), so the gateway never sends G again itself.
HOLD = 2.0
TIMEOUTS = """
[loops.timeouts]
host_latency = 5.0
"""


@pytest.fixture
async def rig(tmp_path: Path) -> AsyncIterator[RestartRig]:
    rig = RestartRig(tmp_path, SCALE)
    await rig.start_sim()
    rig.config.write_text(rig.config.read_text("utf-8") + TIMEOUTS, "utf-8")
    try:
        yield rig
    finally:
        await rig.close()


async def _until_heard(rig: RestartRig, frame: str, request: asyncio.Future[object]) -> None:
    """Until the simulated line has heard ``frame`` (polls the control surface's trace);
    fails at once when ``request`` was answered first."""
    async with asyncio.timeout(WAIT):
        while await rig.heard(frame) == 0:
            assert not request.done(), request.result()


async def test_a_program_run_cut_short_by_a_kill_is_outcome_unknown_and_never_runs_again(
    rig: RestartRig,
) -> None:
    key = {"Idempotency-Key": "mes-order-4711-run"}
    gateway = await rig.serve()
    async with httpx.AsyncClient(base_url=gateway.url + "/api/v1", timeout=WAIT) as client:
        upload = await client.put(PROGRAM, json={"text": ENDLESS})
        assert upload.status_code == 200, upload.text
        assert await rig.heard(RUN) == 0
        await rig.control(op="fault", kind="late", probability=1.0, delay=HOLD)
        first = asyncio.ensure_future(client.post(f"{PROGRAM}/run", json={}, headers=key))
        await _until_heard(rig, RUN, first)
        rig.kill()  # G is on the line, its answer is not back: the client never hears
        await rig.wait_killed()
        with pytest.raises(httpx.TransportError):
            await first
    await rig.control(op="clear_faults")
    assert await rig.heard(RUN) == 1

    gateway = await rig.serve()
    async with httpx.AsyncClient(base_url=gateway.url + "/api/v1", timeout=WAIT) as client:
        retry = await client.post(f"{PROGRAM}/run", json={}, headers=key)
        assert retry.status_code == 409, retry.text
        assert retry.headers["idempotent-replayed"] == "true"
        problem = retry.json()
        assert problem["type"] == "urn:rc233-gateway:problem:idempotency-outcome-unknown"
        assert problem["key"] == "mes-order-4711-run" and problem["outcome"] == "unknown"
        assert problem["field"] == "header.Idempotency-Key"
        assert "POST /api/v1/controllers/stage/program/run" in problem["detail"]
        again = await client.post(f"{PROGRAM}/run", json={}, headers=key)
        assert again.status_code == 409 and again.json()["accepted"] == problem["accepted"]
        # the same key for another body is still refused as a reuse, not run
        other = await client.post(f"{PROGRAM}/run", json={"label": "1"}, headers=key)
        assert other.status_code == 422 and other.json()["field"] == "header.Idempotency-Key"
    assert await rig.heard(RUN) == 1  # the retries sent nothing
    assert await rig.heard(RUN + "1") == 0
