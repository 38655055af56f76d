"""The audit log: one JSON line per mutating request, on a small app of the test's own."""

from __future__ import annotations

import asyncio
import hashlib
import json
from collections.abc import AsyncIterator
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Annotated, Any

import httpx
import pytest
from fastapi import Depends, FastAPI, Request
from pydantic import BaseModel

from gateway.api.audit import audit_note, install_audit
from gateway.api.audit_log import audit_exposition
from gateway.api.problems import install_problem_handlers
from gateway.api.security import (
    AuthConfig,
    Principal,
    TokenBook,
    TokenEntry,
    hash_token,
    install_security,
    require,
)
from gateway.service.audit import AuditRecord, verify
from gateway.service.roles import Role
from tests.support.sim_app import running_app

TOKENS = {"vera": ("viewer-secret", Role.VIEWER), "otto": ("operator-secret", Role.OPERATOR),
          "ada": ("admin-secret", Role.ADMIN)}  # fmt: skip


class Move(BaseModel):
    position: int
    note: str = ""


def build_app(audit: AuditRecord) -> FastAPI:
    app = FastAPI()
    app.state.moved = []
    install_problem_handlers(app)
    book = TokenBook(TokenEntry(n, role, hash_token(t)) for n, (t, role) in TOKENS.items())
    install_security(app, AuthConfig(book))
    install_audit(app, audit)

    @app.post("/api/v1/axes/{ident}/move", status_code=202)
    async def move(
        ident: str,
        body: Move,
        request: Request,
        _: Annotated[Principal, Depends(require(Role.OPERATOR))],
    ) -> dict[str, str]:
        # what a motion handler records: the frames it sent and the positions around it
        audit_note(request, bytes_sent=[b"$1F1\r", f"$14{body.position}\r".encode()])
        audit_note(request, position_before=0, position_after=body.position, operation="op-7")
        audit_note(request, result="done", status=999, path="/forged")  # core keys are kept
        app.state.moved.append(body.position)
        return {"operation": "op-7"}

    @app.get("/api/v1/axes")
    async def read(_: Annotated[Principal, Depends(require(Role.VIEWER))]) -> list[str]:
        return []

    @app.delete("/api/v1/leases/{ident}")
    async def bug(ident: str) -> None:
        raise RuntimeError("a defect")

    return app


@dataclass
class Audited:
    audit: AuditRecord
    client: httpx.AsyncClient
    path: Path | None

    async def all_lines(self) -> list[dict[str, Any]]:
        await self.audit.flush()
        assert self.path is not None
        return [json.loads(line) for line in self.path.read_text("utf-8").splitlines()]

    async def lines(self) -> list[dict[str, Any]]:
        """The outcome entries (those written when the response started)."""
        return [e for e in await self.all_lines() if e.get("event") != "intent"]


@pytest.fixture
async def audited(tmp_path: Path) -> AsyncIterator[Audited]:
    path = tmp_path / "audit.jsonl"
    audit = AuditRecord(path)
    transport = httpx.ASGITransport(app=build_app(audit), client=("203.0.113.9", 4711))
    async with httpx.AsyncClient(transport=transport, base_url="http://localhost") as client:
        yield Audited(audit, client, path)
    await audit.close()


def auth(name: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {TOKENS[name][0]}"}


async def test_a_mutating_request_is_one_line_with_what_it_did(audited: Audited):
    before = datetime.now(UTC)
    r = await audited.client.post(
        "/api/v1/axes/main.1.1/move?wait=true", json={"position": 1000}, headers=auth("otto")
    )
    assert r.status_code == 202
    await audited.client.get("/api/v1/axes", headers=auth("otto"))  # a read: not audited
    [entry] = await audited.lines()
    when = datetime.fromisoformat(entry["time"].replace("Z", "+00:00"))
    assert entry["time"].endswith("Z")
    assert before - timedelta(seconds=1) <= when <= datetime.now(UTC)
    assert entry["token"] == "otto" and entry["role"] == "operator"
    assert entry["client"] == "203.0.113.9:4711"
    assert (entry["method"], entry["path"], entry["query"]) == (
        "POST",
        "/api/v1/axes/main.1.1/move",
        "wait=true",
    )
    assert entry["body"] == {"position": 1000}
    assert entry["status"] == 202
    assert entry["bytes_sent"] == ["$1F1\r", "$141000\r"]
    assert (entry["position_before"], entry["position_after"]) == (0, 1000)
    assert entry["operation"] == "op-7" and entry["result"] == "done"
    intent, outcome = await audited.all_lines()
    assert outcome is not None and entry["intent"] == intent["seq"] == 1
    assert intent["event"] == "intent" and intent["body"] == {"position": 1000}
    assert (intent["token"], intent["path"]) == ("otto", "/api/v1/axes/main.1.1/move")
    assert "status" not in intent


async def test_refused_requests_are_audited_with_their_status(audited: Audited):
    await audited.client.post("/api/v1/axes/x/move", json={"position": 1})
    await audited.client.post("/api/v1/axes/x/move", json={"position": 1}, headers=auth("vera"))
    await audited.client.post("/api/v1/axes/x/move", json={"position": "far"}, headers=auth("ada"))
    await audited.client.delete("/api/v1/leases/x")
    entries = await audited.lines()
    assert [(e["token"], e["status"]) for e in entries] == [
        (None, 401),
        ("vera", 403),
        ("ada", 422),  # the token is checked with the body: who sent bad input is named
        (None, 500),
    ]
    assert entries[2]["body"] == {"position": "far"}
    assert "bytes_sent" not in entries[0]
    # Only a principal who may act has an entry written ahead (ada's, refused later: 422).
    assert [e["seq"] for e in await audited.all_lines()] == [1, 2, 3, 4, 5]
    assert [e.get("intent") for e in entries] == [None, None, 3, None]


async def test_a_long_body_is_kept_as_its_first_kib_with_its_sha256(audited: Audited):
    note = "x" * 10_000
    text = json.dumps({"position": 5, "note": note})
    r = await audited.client.post(
        "/api/v1/axes/x/move",
        content=text.encode(),
        headers={**auth("otto"), "content-type": "application/json"},
    )
    assert r.status_code == 202
    intent, entry = await audited.all_lines()
    assert entry["body"] == text[:1024]
    assert entry["body_truncated"] is True
    assert entry["body_bytes"] == len(text)
    assert entry["body_sha256"] == hashlib.sha256(text.encode()).hexdigest()
    assert intent["body"] == text[:1024] and intent["body_sha256"] == entry["body_sha256"]
    assert all(len(line) < 2048 for line in audited.path.read_bytes().splitlines())  # type: ignore[union-attr]


async def test_get_audit_is_for_admins_and_pages_by_seq(audited: Audited):
    for position in range(5):
        await audited.client.post(
            "/api/v1/axes/x/move", json={"position": position}, headers=auth("otto")
        )
    assert (await audited.client.get("/api/v1/audit", headers=auth("otto"))).status_code == 403
    assert (await audited.client.get("/api/v1/audit")).status_code == 401
    await audited.audit.flush()  # outcomes are queued: the page shows what is in the file
    page = (await audited.client.get("/api/v1/audit?limit=2", headers=auth("ada"))).json()
    # the newest, oldest first: the last move's entry written ahead, then its outcome
    assert [e["body"]["position"] for e in page["entries"]] == [4, 4]
    assert [e.get("event") for e in page["entries"]] == ["intent", None]
    assert page["last_seq"] == 10
    after = (await audited.client.get("/api/v1/audit?since=1&limit=2", headers=auth("ada"))).json()
    assert [e["seq"] for e in after["entries"]] == [2, 3]
    assert after["entries"][0]["bytes_sent"] == ["$1F1\r", "$140\r"]
    assert after["entries"][0]["intent"] == 1
    # the failed reads of /audit above were GETs: never audited
    assert len(await audited.lines()) == 5


async def test_get_audit_shows_the_entries_of_mqtt_and_opcua_which_have_no_query(
    audited: Audited,
):
    # the other faces write to the same record; their entries carry "query": null
    dcmd = {"time": "2026-01-01T00:00:00Z", "token": "otto", "client": "mqtt", "method": "DCMD",
            "path": "spBv1.0/plant/DCMD/cmd/gantry", "query": None, "status": 200}  # fmt: skip
    audited.audit.record(dcmd)
    opcua = {**dcmd, "client": "opcua", "method": "OPCUA", "path": "axes/x/MoveAbsolute"}
    audited.audit.record({**opcua, "status": "BadInvalidState"})  # an OPC UA status code
    await audited.audit.flush()
    got = await audited.client.get("/api/v1/audit", headers=auth("ada"))
    assert got.status_code == 200, got.text
    assert [(e["method"], e["query"], e["status"]) for e in got.json()["entries"]] == [
        ("DCMD", None, 200),
        ("OPCUA", None, "BadInvalidState"),
    ]


async def test_since_takes_a_time_and_refuses_anything_else(audited: Audited):
    await audited.client.post("/api/v1/axes/x/move", json={"position": 1}, headers=auth("otto"))
    await audited.audit.flush()
    past = (datetime.now(UTC) - timedelta(minutes=1)).isoformat()
    future = (datetime.now(UTC) + timedelta(minutes=1)).isoformat().replace("+00:00", "Z")
    got = await audited.client.get("/api/v1/audit", params={"since": past}, headers=auth("ada"))
    assert len(got.json()["entries"]) == 2  # written ahead, and the outcome
    got = await audited.client.get("/api/v1/audit", params={"since": future}, headers=auth("ada"))
    assert got.json()["entries"] == []
    bad = await audited.client.get("/api/v1/audit?since=yesterday", headers=auth("ada"))
    assert bad.status_code == 422
    assert bad.json()["field"] == "query.since"
    too_many = await audited.client.get("/api/v1/audit?limit=0", headers=auth("ada"))
    assert too_many.status_code == 422 and too_many.json()["field"] == "query.limit"


async def test_without_a_path_the_log_is_in_memory_only(tmp_path: Path):
    audit = AuditRecord(None)
    transport = httpx.ASGITransport(app=build_app(audit))
    async with httpx.AsyncClient(transport=transport, base_url="http://localhost") as client:
        await client.post("/api/v1/axes/x/move", json={"position": 3}, headers=auth("otto"))
        await audit.flush()
        page = (await client.get("/api/v1/audit", headers=auth("ada"))).json()
    await audit.close()
    assert [e["body"] for e in page["entries"]] == [{"position": 3}, {"position": 3}]
    assert page["entries"][1]["intent"] == page["entries"][0]["seq"] == 1
    assert list(tmp_path.iterdir()) == []


async def test_the_memory_keeps_the_newest_entries():
    audit = AuditRecord(None, memory=3)
    for i in range(5):
        audit.record({"time": "t", "method": "POST", "path": f"/{i}"})
    assert [e["path"] for e in audit.entries(limit=10)] == ["/2", "/3", "/4"]
    assert audit.last_seq == 5


async def test_close_writes_every_entry_in_order(tmp_path: Path):
    path = tmp_path / "a" / "audit.jsonl"
    path.parent.mkdir()
    audit = AuditRecord(path)
    for i in range(2500):
        audit.record({"time": "t", "method": "PUT", "path": f"/{i}", "bytes_sent": [b"\x02\xff"]})
    await audit.close()  # graceful shutdown: nothing queued is lost
    lines = [json.loads(line) for line in path.read_text("utf-8").splitlines()]
    assert [e["seq"] for e in lines] == list(range(1, 2501))
    assert lines[-1]["path"] == "/2499"
    assert lines[0]["bytes_sent"] == ["\x02\xff"]  # frames as Latin-1 text, byte for byte


async def test_a_disk_that_fails_refuses_what_acts_and_loses_no_record(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
):
    folder = tmp_path / "missing-dir"
    audit = AuditRecord(folder / "audit.jsonl", retry_interval=0.05)
    app = build_app(audit)
    transport = httpx.ASGITransport(app=app)
    async with httpx.AsyncClient(transport=transport, base_url="http://localhost") as client:
        r = await client.post("/api/v1/axes/x/move", json={"position": 3}, headers=auth("otto"))
        assert r.status_code == 503, r.text
        assert r.headers["Retry-After"] == "1"
        assert r.json()["field"] == "audit" and r.json()["outcome"] == "not_done"
        assert app.state.moved == []  # the route never ran: nothing was sent
        assert not audit.healthy and audit.refused == 1
        assert "cannot be written" in caplog.text
        folder.mkdir()  # the disk is back: the writer's own retry gets through
        await asyncio.wait_for(audit.until_healthy(), 10)
    await audit.close()
    lines = [json.loads(x) for x in (folder / "audit.jsonl").read_text("utf-8").splitlines()]
    assert [(e["seq"], e.get("status"), e.get("event")) for e in lines] == [
        (1, 503, None),  # the refusal, kept until the file took writes
        (2, None, "audit_resumed"),
    ]
    assert lines[1]["refused"] == 1


async def test_a_lone_surrogate_reaches_the_file_and_keeps_the_writer_alive(audited: Audited):
    # A body the gate would refuse, sent to an app without it: the record must still hold.
    for note in ("\ud800", "ok", "\udfff tail"):
        body = json.dumps({"position": 1, "note": note}).encode()
        r = await audited.client.post(
            "/api/v1/axes/x/move",
            content=body,
            headers={**auth("otto"), "Content-Type": "application/json"},
        )
        assert r.status_code == 202
    lines = await audited.lines()
    assert [e["seq"] for e in lines] == [2, 4, 6]  # each after the entry written ahead of it
    assert [e["body"]["note"] for e in lines] == ["\ud800", "ok", "\udfff tail"]
    assert audited.audit.write_errors == 0


async def test_a_write_that_fails_is_loud_and_retried(tmp_path: Path):
    path = tmp_path / "audit.jsonl"
    path.mkdir()  # a directory where the file should be: every write fails
    # The writer's own retry (tested on its own) would race the next record from a thread on
    # a slow machine; here only a request wakes it.
    audit = AuditRecord(path, retry_interval=3600)
    audit.record({"time": "t", "method": "POST", "path": "/1"})
    await audit.flush()
    assert not audit.healthy
    assert "audit.jsonl" in (audit.last_error or "")
    assert "rc233_audit_write_errors_total 0" not in audit_exposition(audit)
    assert "rc233_audit_log_ok 0" in audit_exposition(audit)
    path.rmdir()  # the disk is back: the next write carries the line that failed
    audit.record({"time": "t", "method": "POST", "path": "/2"})
    await audit.close()
    lines = [json.loads(line) for line in path.read_text("utf-8").splitlines()]
    assert [(e["seq"], e["path"]) for e in lines[:2]] == [(1, "/1"), (2, "/2")]
    assert lines[2]["event"] == "audit_resumed"
    assert audit.healthy
    assert "rc233_audit_log_ok 1" in audit_exposition(audit)


async def test_a_request_refused_before_authentication_names_its_token(audited: Audited):
    r = await audited.client.delete("/api/v1/audit", headers=auth("ada"))
    assert r.status_code == 405
    r = await audited.client.post("/api/v1/nowhere", headers=auth("otto"))
    assert r.status_code == 404
    lines = await audited.lines()
    assert [(e["status"], e["token"], e["role"]) for e in lines] == [
        (405, "ada", "admin"),
        (404, "otto", "operator"),
    ]


async def test_a_token_in_the_query_is_not_recorded(audited: Audited):
    r = await audited.client.post(
        "/api/v1/axes/x/move?token=operator-secret&wait=true",
        json={"position": 1},
        headers=auth("otto"),
    )
    assert r.status_code == 202
    intent, line = await audited.all_lines()
    assert line["query"] == intent["query"] == "token=***&wait=true"
    assert "operator-secret" not in audited.path.read_text("utf-8")  # type: ignore[union-attr]


async def test_a_failing_audit_file_makes_the_gateway_not_ready_until_it_takes_writes(
    tmp_path: Path,
):
    path = tmp_path / "audit.jsonl"
    async with running_app(("1",), audit_log=path) as api:
        r = await api.client.post("/axes/x/stop")
        assert r.status_code == 200, r.text
        assert (await api.client.get("http://localhost/readyz")).status_code == 200
        audit: AuditRecord = api.services.audit
        audit.retry_interval = 0.05
        await audit.flush()
        path.unlink()
        path.mkdir()  # the file is gone and cannot be made again
        r = await api.client.post("/axes/x/stop")
        assert r.status_code == 200, r.text  # a stop passes, its entry queued
        r = await api.client.post("/axes/x/move", json={"position": 10, "unit": "pulse"})
        assert r.status_code == 503 and r.headers["Retry-After"] == "1", r.text
        ready = await api.client.get("http://localhost/readyz")
        assert ready.status_code == 503
        assert "audit log" in ready.json()["detail"]
        metrics = (await api.client.get("http://localhost/metrics")).text
        assert "rc233_audit_write_errors_total 0" not in metrics
        assert "rc233_audit_refused_total 1" in metrics
        assert "rc233_audit_log_ok 0" in metrics
        path.rmdir()  # space again: readiness comes back with no request in between
        await asyncio.wait_for(audit.until_healthy(), 10)
        assert (await api.client.get("http://localhost/readyz")).status_code == 200
    lines = [json.loads(line) for line in path.read_text("utf-8").splitlines()]
    # the stop's entry, logged and queued while the file failed, is in the file now
    stops = [e for e in lines if e["path"].endswith("/stop")]
    assert [(e.get("event"), e.get("late")) for e in stops[-2:]] == [("intent", True), (None, None)]
    assert any(e.get("event") == "audit_resumed" for e in lines)
    assert verify([path]).broken is None
