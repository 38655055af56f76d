"""A DCMD's audit record: written ahead of what it does, bounded, never holding a stop back.

``DeviceCommands`` as ``serve`` builds it (the API's token book and audit log, written ahead
with ``AuditRecord.write_ahead``) on the real app and simulated loop; the file and what the
simulated controller heard are read back.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from gateway.mqtt.dcmd import DeviceCommands
from gateway.mqtt.sparkplug import Value
from gateway.service.audit import AuditRecord
from tests.support.sim_app import TOKENS, running_app

TOPIC = "spBv1.0/plant/DCMD/cmd/gantry"


def _handler(api: Any) -> DeviceCommands:
    audit: AuditRecord = api.services.audit
    lookup = api.app.state.auth.book.principal
    return DeviceCommands(api.services.axes, lookup, audit.record, ahead=audit.write_ahead)


def _entries(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_bytes().splitlines()]


async def test_a_flood_of_metrics_is_one_short_line_with_the_sha256_of_the_whole(tmp_path: Path):
    path = tmp_path / "audit.jsonl"
    async with running_app(("1",), roles=True, audit_log=path) as api:
        ctl = api.runtime.topology.controller("sim.1")
        metrics: dict[str, Value] = {f"Axis/x/M{i}": True for i in range(200_000)}
        whole = json.dumps(dict(metrics), ensure_ascii=False).encode()
        status, _ = await _handler(api).handle(TOPIC, ctl, {"x": "sim.1.1"}, metrics)
        assert status == 401  # no token: refused, and recorded once
        await api.services.audit.flush()
    [line] = path.read_bytes().splitlines()
    assert len(line) < 2048  # not 4.8 MiB
    entry = json.loads(line)
    assert entry["body_truncated"] is True and entry["body_bytes"] == len(whole)
    assert entry["body_sha256"] == hashlib.sha256(whole).hexdigest()


async def test_a_dcmd_stop_is_written_ahead_and_passes_when_the_file_fails(tmp_path: Path):
    path = tmp_path / "audit.jsonl"
    async with running_app(("1",), roles=True, audit_log=path) as api:
        ctl = api.runtime.topology.controller("sim.1")
        handler = _handler(api)
        token = TOKENS["operator"][0]
        stop: dict[str, Value] = {"Command/Token": token, "Axis/x/Stop": True}
        assert (await handler.handle(TOPIC, ctl, {"x": "sim.1.1"}, dict(stop)))[0] == 200
        await api.services.audit.flush()
        intent, outcome = _entries(path)
        assert intent["event"] == "intent" and outcome["intent"] == intent["seq"]
        assert token not in path.read_text("utf-8")
        path.unlink()
        path.mkdir()  # the file cannot be written any more
        mark = api.mark()
        status, _ = await handler.handle(TOPIC, ctl, {"x": "sim.1.1"}, dict(stop))
        assert status == 200 and "SS" in api.heard("1", since=mark)  # the stop went out
        ack: dict[str, Value] = {"Command/Token": token, "Axis/x/Errors/Ack": True}
        status, result = await handler.handle(TOPIC, ctl, {"x": "sim.1.1"}, ack)
        assert status == 503 and "AuditUnavailable" in result  # what is not a stop waits
        path.rmdir()
        await api.services.audit.flush()
    entries = _entries(path)  # the stop's entries, queued while the file failed
    assert [(e.get("event"), e.get("late"), e.get("status")) for e in entries[:3]] == [
        ("intent", True, None),
        (None, None, 200),
        (None, None, 503),
    ]
