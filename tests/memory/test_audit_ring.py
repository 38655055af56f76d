"""The audit entries in memory stay within count and bytes; older pages come from the files.

``AuditRecord`` writes a real chained file (rotated by size) as the gateway does; the pages
asked for are compared with what the file holds.
"""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from gateway.service.audit import MEMORY, MEMORY_BYTES, AuditRecord, RotationPolicy


def _entry(i: int, body: str = "") -> dict[str, Any]:
    return {"time": f"2026-01-01T00:00:{i // 1000:02d}.{i % 1000:03d}Z", "method": "POST",
            "path": f"/{i}", "body": body}  # fmt: skip


async def _fill(audit: AuditRecord, count: int, body: str = "") -> None:
    for i in range(count):
        audit.record(_entry(i, body))
    await audit.flush()


def _paths(entries: list[dict[str, Any]]) -> list[str]:
    return [e["path"] for e in entries]


async def test_memory_keeps_at_most_its_count_of_entries(tmp_path: Path):
    audit = AuditRecord(tmp_path / "audit.jsonl", memory=50)
    await _fill(audit, 400)
    count, _ = audit.kept
    assert count == 50
    assert audit.last_seq == 400
    await audit.close()


async def test_memory_keeps_at_most_its_bytes_of_entries(tmp_path: Path):
    audit = AuditRecord(tmp_path / "audit.jsonl", memory=1000, memory_bytes=20_000)
    await _fill(audit, 300, body="x" * 900)  # some 1 KB each: 20 of them fill the bytes
    count, held = audit.kept
    assert held <= 20_000
    assert 15 <= count <= 20
    await audit.close()


def test_the_default_depth_is_what_the_api_serves_fast():
    assert MEMORY == 1_000
    assert MEMORY_BYTES <= 4 * 1024 * 1024


async def test_the_newest_page_deeper_than_memory_is_read_from_the_rotated_files(tmp_path: Path):
    path = tmp_path / "audit.jsonl"
    audit = AuditRecord(path, memory=20, rotation=RotationPolicy(max_bytes=4_000, keep=50))
    await _fill(audit, 300)
    assert path.with_name("audit.jsonl.3").exists()  # the page spans several files
    page = await audit.page(limit=120)
    assert _paths(page) == [f"/{i}" for i in range(180, 300)]
    assert [e["seq"] for e in page] == list(range(181, 301))
    small = await audit.page(limit=5)  # from memory
    assert _paths(small) == [f"/{i}" for i in range(295, 300)]
    await audit.close()


async def test_a_page_after_a_seq_older_than_memory_is_read_from_the_files(tmp_path: Path):
    path = tmp_path / "audit.jsonl"
    audit = AuditRecord(path, memory=20, rotation=RotationPolicy(max_bytes=4_000, keep=50))
    await _fill(audit, 300)
    page = await audit.page(since=10, limit=25)
    assert [e["seq"] for e in page] == list(range(11, 36))
    tail = await audit.page(since=290, limit=25)  # in memory
    assert [e["seq"] for e in tail] == list(range(291, 301))
    moment = datetime(2026, 1, 1, 0, 0, 0, 41_000, tzinfo=UTC)  # entry /41's time
    by_time = await audit.page(after=moment, limit=3)
    assert _paths(by_time) == ["/42", "/43", "/44"]
    await audit.close()


async def test_a_page_never_reaches_past_what_rotation_kept(tmp_path: Path):
    path = tmp_path / "audit.jsonl"
    audit = AuditRecord(path, memory=10, rotation=RotationPolicy(max_bytes=4_000, keep=2))
    await _fill(audit, 300)
    files = (path.with_name("audit.jsonl.2"), path.with_name("audit.jsonl.1"), path)
    on_disk = [json.loads(line) for f in files for line in f.read_bytes().splitlines()]
    page = await audit.page(since=0, limit=10_000)
    assert page == on_disk
    await audit.close()
