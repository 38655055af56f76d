"""A jog whose line is cut while it runs is stopped once the line is back, through real
processes: ``rc233-gateway serve`` on the TCP line of ``rc233-gateway sim --tcp``, the line cut
and restored with the simulator's control surface, the operation followed over the WebSocket.

The holder's release (the dashboard's release-to-stop) could not reach the controller while the
line was down: the controller jogged on alone. Once the loop is up, the gateway sends ``SS``
(§10 SS), audits it, and the ``unknown`` operation is re-resolved with what was read back.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import httpx
import pytest

from tests.support.restart_rig import WAIT, RestartRig

#: Real time: a Low-speed jog goes on for as long as the test needs it to.
SCALE = 1.0


@pytest.fixture
async def rig(tmp_path: Path) -> AsyncIterator[RestartRig]:
    rig = RestartRig(tmp_path, SCALE)
    await rig.start_sim()
    try:
        yield rig
    finally:
        await rig.close()


async def test_a_jog_whose_line_was_cut_is_stopped_once_the_line_is_back(
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
        assert jog["frames"] == ["$17"], jog  # §10 7: CW at Low
        if jog["state"] != "moving":
            await until(lambda data: data["id"] == jog["id"] and data["state"] == "moving")
        await rig.control(op="cut", cut=True)
        lost = await until(lambda data: data["id"] == jog["id"] and data["state"] == "unknown")
        assert lost["error"]["kind"] == "loop_down", lost
        # The release cannot reach it: the stop is refused while the loop is down.
        release = await client.post("/axes/x/stop", json={"mode": "decelerate"})
        assert release.status_code == 503, release.text
        alone = await rig.axis("1", 1)
        assert alone["moving"], alone  # nobody stops it: the controller jogs on
        assert await rig.heard("$1SS") == 0

        await rig.control(op="cut", cut=False)
        final = await until(lambda data: data["id"] == jog["id"] and data["state"] != "unknown")
        listed = (await client.get(f"/operations/{jog['id']}")).json()
        audit = (await client.get("/audit", params={"limit": 100})).json()
        stood = await rig.axis("1", 1)
        assert not stood["moving"] and stood["position"] == listed["position"], stood
        assert await rig.heard("$1SS") == 1
        # The controller is free again for a new motion.
        again = await client.post("/axes/x/jog", json={"direction": "ccw", "speed": "low"})
        assert again.status_code in (200, 202), again.text
        await client.post("/axes/x/stop", json={"mode": "decelerate"})

    assert await rig.heard("$1S") == 0  # the decelerating stop, not the abrupt one
    assert final["state"] == listed["state"] == "failed", final
    assert listed["error"]["kind"] == "loop_down" and listed["error"]["outcome"] == "not_done"
    assert "$1SS" in listed["error"]["detail"], listed["error"]
    assert listed["position"] > alone["position"]  # it had jogged on until the stop
    assert listed["frames"] == ["$17"]  # the jog's own frames; the stop is the audit's

    entries = audit["entries"]
    stops = [e for e in entries if e.get("event") == "linkup_stop"]
    assert [(s["bytes_sent"], s["result"], s["operation"]) for s in stops] == [
        (["$1SS"], "done", jog["id"])
    ], entries
    verdicts = [e for e in entries if e.get("event") == "operation_resolved"]
    assert [v["operation"]["state"] for v in verdicts] == ["failed"], entries
    assert stops[0]["seq"] < verdicts[0]["seq"]  # stopped first, then judged
    log = "".join(gateway.log)
    assert "ran while its loop was down; stopped it: $1SS" in log, log
