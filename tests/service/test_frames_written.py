"""The frames a client and the audit are shown as sent are the bytes the gateway wrote: with
SUM1 on (§10 SUM) a move's carry their checksum, in its operation and in its audit entry, as
the simulated controller heard them (the app on the simulated line)."""

from __future__ import annotations

import json
from pathlib import Path

from gateway.protocol.framing import checksum
from tests.support.sim_app import json_of, running_app

WAIT = 20.0


def summed(text: str) -> str:
    """``text`` as a SUM1 frame without its CR: the two hex digits of its byte sum added."""
    return text + checksum(text.encode("ascii")).decode("ascii")


async def test_a_moves_operation_and_audit_entry_show_its_frames_with_their_checksum(
    tmp_path: Path,
) -> None:
    audit_log = tmp_path / "audit.jsonl"
    async with running_app(("1",), audit_log=audit_log) as api:
        r = await api.client.post("/controllers/sim.1/commands", json={"command": "SUM1"})
        assert r.status_code == 200 and json_of(r)["outcome"] == "done", r.text
        mark = api.mark()
        r = await api.client.post(
            "/axes/x/move?wait=true", json={"position": 1500, "unit": "pulse"}
        )
        assert r.status_code == 200, r.text
        view = json_of(r)
        # the caller's two commands (2{pp}, 3), without the scheduler's F and pre-reads
        expected = [summed("$121500"), summed("$13")]
        assert view["frames"] == expected
        heard = [t for t in api.heard("1", mark) if t.startswith(("21500", "3"))]
        assert heard == [f[2:] for f in expected]  # as the controller heard them
        stored = json_of(await api.client.get(f"/operations/{view['id']}"))
        assert stored["frames"] == expected
        await api.services.audit.flush()
    entries = [json.loads(line) for line in audit_log.read_text("utf-8").splitlines()]
    moves = [e for e in entries if e.get("path", "").endswith("/axes/x/move") and "status" in e]
    assert len(moves) == 1, entries
    assert moves[0]["bytes_sent"] == expected
    assert moves[0]["operation"] == view["id"]
