"""The record outlives the gateway: a move retried with its ``Idempotency-Key`` after the
gateway was killed mid-move (or stopped after the move) is answered from the state directory
and never sent again; the operation cut short is resolved by reading the axis back.

Real processes: ``rc233-gateway sim --tcp`` stays up (the machine goes on) while ``serve``
processes on one configuration and one ``state_dir`` are killed and started again.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from pathlib import Path

import httpx
import pytest

from tests.support.restart_rig import WAIT, RestartRig

#: Real time: a 9,000-pulse move takes some 4 s (3,000 pulses: 1.3 s), so that it is still
#: going when the gateway is killed, even on a busy machine.
SCALE = 1.0
MOVE = {"position": 9000, "unit": "pulse"}


@pytest.fixture
async def rig(tmp_path: Path) -> AsyncIterator[RestartRig]:
    rig = RestartRig(tmp_path, SCALE)
    await rig.start_sim()
    try:
        yield rig
    finally:
        await rig.close()


async def test_a_key_accepted_before_a_kill_is_replayed_after_the_restart_and_never_moves_again(
    rig: RestartRig,
) -> None:
    key = {"Idempotency-Key": "mes-order-4711-move"}
    gateway = await rig.serve()
    async with (
        httpx.AsyncClient(base_url=gateway.url + "/api/v1", timeout=WAIT) as client,
        rig.events() as until,
    ):
        # The MES waits for the end: the gateway dies before it can answer.
        first = asyncio.ensure_future(client.post("/axes/x/move?wait=true", json=MOVE, headers=key))
        op = await until(lambda data: data["state"] == "moving")
        rig.kill()  # mid-move: the controller goes on alone
        await rig.wait_killed()
        with pytest.raises(httpx.TransportError):
            await first
    assert (await rig.axis("1", 1))["position"] < 9000  # killed before the move's end
    frames = op["frames"]  # the target (§10 2) and the start (§10 3)
    assert [await rig.heard(frame) for frame in frames] == [1, 1], frames

    gateway = await rig.serve()
    async with httpx.AsyncClient(base_url=gateway.url + "/api/v1", timeout=WAIT) as client:
        async with rig.events() as until:
            retry = await client.post("/axes/x/move?wait=true", json=MOVE, headers=key)
            assert retry.headers.get("idempotent-replayed") == "true", retry.text
            assert retry.status_code in (200, 202), retry.text
            assert retry.json()["id"] == op["id"]
            assert retry.headers["location"] == f"/api/v1/operations/{op['id']}"
            resolved = (await client.get(f"/operations/{op['id']}")).json()
            if resolved["state"] not in ("done", "failed", "unknown"):
                resolved = await until(
                    lambda data: (
                        data["id"] == op["id"] and data["state"] in ("done", "failed", "unknown")
                    )
                )
        assert resolved["state"] == "done", resolved
        assert resolved["position"] == 9000 and resolved["error"] is None
        again = await client.post("/axes/x/move?wait=true", json=MOVE, headers=key)
        assert again.status_code == 200 and again.headers["idempotent-replayed"] == "true"
        assert again.json()["state"] == "done"
        listed = (await client.get(f"/operations/{op['id']}")).json()
        assert listed["state"] == "done" and listed["frames"] == frames
    assert [await rig.heard(frame) for frame in frames] == [1, 1]  # the retries sent nothing
    assert (await rig.axis("1", 1))["position"] == 9000


async def test_a_completed_move_is_replayed_after_a_clean_restart(rig: RestartRig) -> None:
    key = {"Idempotency-Key": "mes-order-4712-move"}
    gateway = await rig.serve()
    async with httpx.AsyncClient(base_url=gateway.url + "/api/v1", timeout=WAIT) as client:
        first = await client.post("/axes/x/move?wait=true", json={**MOVE, "position": 1000},
                                  headers=key)  # fmt: skip
        assert first.status_code == 200 and first.json()["state"] == "done", first.text
    await rig.stop()
    target, start = first.json()["frames"]  # $121000 (§10 2), $13 (§10 3)

    gateway = await rig.serve()
    async with httpx.AsyncClient(base_url=gateway.url + "/api/v1", timeout=WAIT) as client:
        retry = await client.post("/axes/x/move?wait=true", json={**MOVE, "position": 1000},
                                  headers=key)  # fmt: skip
        assert retry.status_code == 200 and retry.headers["idempotent-replayed"] == "true"
        assert retry.content == first.content  # the first answer, byte for byte
        stored = (await client.get(f"/operations/{first.json()['id']}")).json()
        assert stored["state"] == "done" and stored["position"] == 1000
        # the same key for another body is still refused after the restart
        other = await client.post("/axes/x/move", json={**MOVE, "position": 10}, headers=key)
        assert other.status_code == 422 and other.json()["field"] == "header.Idempotency-Key"
        # a new operation's id does not take up an old one's number
        fresh = await client.post("/axes/x/move?wait=true", json={**MOVE, "position": 0})
        assert fresh.status_code == 200
        assert fresh.json()["id"].split("-")[1] != first.json()["id"].split("-")[1]
    assert await rig.heard(target) == 1
    assert await rig.heard(start) == 2  # the first move and the fresh one: the retry sent nothing
    assert (await rig.axis("1", 1))["position"] == 0
