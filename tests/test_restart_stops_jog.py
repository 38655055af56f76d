"""A jog the gateway was holding when it died is stopped by the next gateway at its start.

A jog (``7``/``8``) runs until a stop or a limit sensor; killed, the gateway can no longer
stop it, and the controller goes on alone. The restarted gateway sends the decelerating stop
(``SS``, §10 SS) once the loop is up, records it in the audit log, and resolves the operation
with what it read back (``failed``, kind ``restart``, where the axis stood).

Real processes: ``rc233-gateway sim --tcp`` stays up (the machine goes on) while ``serve``
processes on one configuration and one ``state_dir`` are killed and started again.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import httpx
import pytest

from tests.support.restart_rig import WAIT, RestartRig

#: Real time: a Low-speed jog goes on for as long as the test needs it to.
SCALE = 1.0
FINAL = ("done", "failed", "unknown")


@pytest.fixture
async def rig(tmp_path: Path) -> AsyncIterator[RestartRig]:
    rig = RestartRig(tmp_path, SCALE)
    await rig.start_sim()
    try:
        yield rig
    finally:
        await rig.close()


async def test_a_jog_left_running_by_a_killed_gateway_is_stopped_at_the_restart(
    rig: RestartRig,
) -> None:
    gateway = await rig.serve()
    async with (
        httpx.AsyncClient(base_url=gateway.url + "/api/v1", timeout=WAIT) as client,
        rig.events() as until,
    ):
        started = await client.post("/axes/x/jog", json={"direction": "cw", "speed": "low"})
        assert started.status_code in (200, 202), started.text
        jog = started.json()
        assert jog["kind"] == "jog" and jog["frames"] == ["$17"], jog  # §10 7: CW at Low
        if jog["state"] != "moving":
            await until(lambda data: data["id"] == jog["id"] and data["state"] == "moving")
        await rig.stored(jog["id"], "moving")  # the record a restart reads, with its frames
    rig.kill()  # the holder of the jog is gone with the process
    await rig.wait_killed()
    alone = await rig.axis("1", 1)
    assert alone["moving"], alone  # nobody stops it: the controller jogs on

    gateway = await rig.serve()
    async with (
        httpx.AsyncClient(base_url=gateway.url + "/api/v1", timeout=WAIT) as client,
        rig.events() as until,
    ):
        resolved = (await client.get(f"/operations/{jog['id']}")).json()
        if resolved["state"] not in FINAL:
            resolved = await until(lambda data: data["id"] == jog["id"] and data["state"] in FINAL)
        listed = (await client.get(f"/operations/{jog['id']}")).json()
        audit = (await client.get("/audit", params={"limit": 100})).json()

    # The stop went out once, and the axis stands where the gateway read it back.
    assert await rig.heard("$1SS") == 1
    assert await rig.heard("$1S") == 0  # the decelerating stop, not the abrupt one
    axis = await rig.axis("1", 1)
    assert not axis["moving"], axis
    assert axis["position"] > alone["position"]  # it had gone on jogging until the stop
    assert resolved["state"] == listed["state"] == "failed", resolved
    assert listed["error"]["kind"] == "restart" and listed["error"]["outcome"] == "not_done"
    assert "$1SS" in listed["error"]["detail"], listed["error"]
    assert listed["position"] == axis["position"]
    assert listed["frames"] == ["$17"]  # the jog's own frames; the stop is the audit's

    entries = audit["entries"]
    stops = [e for e in entries if e.get("event") == "restart_stop"]
    assert len(stops) == 1, entries
    assert stops[0]["bytes_sent"] == ["$1SS"] and stops[0]["result"] == "done"
    assert stops[0]["operation"] == jog["id"] and stops[0]["path"].endswith("/stop")
    verdicts = [e for e in entries if e.get("event") == "operation_resolved"]
    assert [v["operation"]["state"] for v in verdicts] == ["failed"], entries
    assert stops[0]["seq"] < verdicts[0]["seq"]  # stopped first, then judged
    log = "".join(gateway.log)
    assert f"operation {jog['id']}" in log and "stopped it: $1SS" in log, log
