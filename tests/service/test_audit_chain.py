"""The audit file: whole lines only, numbered across restarts and rotations, chained, verified.

Each test writes through ``ChainFile`` / ``AuditRecord`` as the gateway does and reads the
bytes on disk back; ``rc233-gateway audit verify`` is run as a user would run it.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

import pytest

from gateway.cli import main
from gateway.service.audit import AuditRecord, ChainFile, RotationPolicy, verify
from gateway.service.audit.bounds import bounded
from gateway.service.audit.chain_file import GENESIS, rotated


def _entries(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_bytes().splitlines()]


def _write(file: ChainFile, count: int, start: int = 0) -> None:
    for i in range(start, start + count):
        file.append({"time": "t", "method": "POST", "path": f"/{i}"}, fsync=False)


def test_lines_are_numbered_and_chained_by_the_sha256_of_the_line_before(tmp_path: Path):
    path = tmp_path / "audit.jsonl"
    _write(ChainFile(path), 3)
    raw = path.read_bytes().splitlines()
    entries = _entries(path)
    assert [e["seq"] for e in entries] == [1, 2, 3]
    assert entries[0]["prev"] == GENESIS
    assert entries[1]["prev"] == hashlib.sha256(raw[0]).hexdigest()
    assert entries[2]["prev"] == hashlib.sha256(raw[1]).hexdigest()
    assert verify([path]).broken is None


def test_the_sequence_and_chain_go_on_after_a_restart_cutting_a_torn_last_line(tmp_path: Path):
    path = tmp_path / "audit.jsonl"
    _write(ChainFile(path), 2)
    with path.open("ab") as file:  # a crash in the middle of a write
        file.write(b'{"seq":3,"prev":"ab","time":"t","token":"operato')
    again = ChainFile(path)  # the gateway starts again
    assert again.last_seq == 2
    _write(again, 2, start=2)
    entries = _entries(path)  # every line whole JSON: nothing glued onto the torn one
    assert [e["seq"] for e in entries] == [1, 2, 3, 4]
    assert verify([path]).broken is None


def test_a_partial_write_is_cut_back_and_never_glued(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    path = tmp_path / "audit.jsonl"
    chain = ChainFile(path)
    _write(chain, 1)
    real_write = os.write

    def half(fd: int, data: bytes) -> int:  # a disk that fills in the middle of the line
        return real_write(fd, bytes(data[: len(data) // 2]))

    monkeypatch.setattr(os, "write", half)
    with pytest.raises(OSError, match="wrote"):
        chain.append({"time": "t", "method": "POST", "path": "/lost"}, fsync=True)
    monkeypatch.setattr(os, "write", real_write)
    assert path.read_bytes().endswith(b"\n")  # the half line is gone
    assert chain.last_seq == 1  # and its number was not used
    _write(chain, 1, start=1)
    assert [e["path"] for e in _entries(path)] == ["/0", "/1"]
    assert [e["seq"] for e in _entries(path)] == [1, 2]
    assert verify([path]).broken is None


def test_a_cut_back_that_fails_is_repaired_before_the_next_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    path = tmp_path / "audit.jsonl"
    chain = ChainFile(path)
    _write(chain, 1)
    real_write, real_truncate = os.write, os.ftruncate

    def half(fd: int, data: bytes) -> int:
        return real_write(fd, bytes(data[:10]))

    def refused(fd: int, size: int) -> None:
        raise OSError("ftruncate refused")

    monkeypatch.setattr(os, "write", half)
    monkeypatch.setattr(os, "ftruncate", refused)
    with pytest.raises(OSError):
        chain.append({"time": "t", "method": "POST", "path": "/lost"}, fsync=False)
    monkeypatch.setattr(os, "write", real_write)
    monkeypatch.setattr(os, "ftruncate", real_truncate)
    assert not path.read_bytes().endswith(b"\n")  # torn, for now
    _write(chain, 1, start=1)
    assert [e["seq"] for e in _entries(path)] == [1, 2]
    assert verify([path]).broken is None


def test_rotation_keeps_sequence_and_chain_across_files_and_restarts(tmp_path: Path):
    path = tmp_path / "audit.jsonl"
    policy = RotationPolicy(max_bytes=1000, keep=3)
    _write(ChainFile(path, policy), 40)
    files = [rotated(path, 3), rotated(path, 2), rotated(path, 1), path]
    assert all(f.exists() for f in files) and not rotated(path, 4).exists()
    assert all(f.stat().st_size <= 1000 for f in files)
    checked = verify(files)
    assert checked.broken is None and checked.last_seq == 40
    assert _entries(rotated(path, 1))[-1]["seq"] + 1 == _entries(path)[0]["seq"]
    # rotated, then killed before the new file had a line: the tail is FILE.1's
    rotated(path, 3).unlink()
    rotated(path, 2).rename(rotated(path, 3))
    rotated(path, 1).rename(rotated(path, 2))
    path.rename(rotated(path, 1))
    again = ChainFile(path, policy)
    assert again.last_seq == 40
    _write(again, 1, start=40)
    assert verify([rotated(path, 2), rotated(path, 1), path]).broken is None
    assert _entries(path)[0]["seq"] == 41


@pytest.mark.parametrize(
    ("damage", "line", "reason"),
    [
        ("change", 3, "not the SHA-256 of the line before"),
        ("remove", 3, "seq 4 follows seq 2"),
        ("glue", 3, "not JSON"),
        ("tear", 5, "torn line"),
    ],
)
def test_verify_names_the_first_break(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], damage: str, line: int, reason: str
):
    path = tmp_path / "audit.jsonl"
    _write(ChainFile(path), 5)
    lines = path.read_bytes().splitlines(keepends=True)
    if damage == "change":  # line 2 says another path: line 3 no longer chains to it
        lines[1] = lines[1].replace(b'"/1"', b'"/X"')
    elif damage == "remove":
        del lines[2]
    elif damage == "glue":
        lines[2] = lines[2][:20] + lines[3]
        del lines[3]
    else:
        lines[4] = lines[4][:-1]
    path.write_bytes(b"".join(lines))
    assert main(["audit", "verify", str(path)]) == 1
    err = capsys.readouterr().err
    assert f"{path}:{line}:" in err and reason in err, err


def test_verify_passes_a_whole_history_with_its_rotated_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
):
    path = tmp_path / "audit.jsonl"
    _write(ChainFile(path, RotationPolicy(max_bytes=500, keep=50)), 30)
    assert main(["audit", "verify", "--rotated", str(path)]) == 0
    assert "30 entries, seq 1..30" in capsys.readouterr().out
    # a file from the middle alone: checked from where it starts
    assert main(["audit", "verify", str(rotated(path, 2))]) == 0
    # two files with one missing between them: the sequence breaks
    assert main(["audit", "verify", str(rotated(path, 3)), str(rotated(path, 1))]) == 1
    assert "follows" in capsys.readouterr().err


def test_a_body_is_cut_at_1_kib_with_the_sha256_of_the_whole():
    metrics = {f"Axis/x/M{i}": True for i in range(200_000)}
    entry = bounded({"time": "t", "method": "DCMD", "path": "t", "body": metrics})
    whole = json.dumps(metrics, ensure_ascii=False).encode()
    assert len(entry["body"].encode()) <= 1024
    assert entry["body_truncated"] is True and entry["body_bytes"] == len(whole)
    assert entry["body_sha256"] == hashlib.sha256(whole).hexdigest()
    assert len(json.dumps(entry)) < 2048


async def test_an_entry_written_ahead_is_on_disk_when_the_call_returns(tmp_path: Path):
    path = tmp_path / "audit.jsonl"
    audit = AuditRecord(path)
    seq = await audit.write_ahead({"time": "t", "method": "POST", "path": "/m"}, motion=True)
    assert seq == 1
    assert _entries(path) == [audit.entries()[0]]  # no close, no flush: it is there
    await audit.close()
    again = AuditRecord(path)
    assert again.last_seq == 1
    assert await again.write_ahead({"time": "t", "method": "POST", "path": "/n"}, motion=True) == 2
    await again.close()


def test_the_audit_settings_reach_the_record_and_bad_ones_are_named(tmp_path: Path):
    from gateway.compose import audit_of
    from gateway.service.audit import FsyncPolicy
    from gateway.service.config import ConfigError, parse_config
    from gateway.service.runtime.simulated import simulated_config

    base = simulated_config(("1",)).model_dump(mode="json", exclude_none=True)
    data = {**base, "audit_log": str(tmp_path / "a.jsonl")}
    data["audit"] = {"fsync": "all", "max_bytes": 65536, "keep": 2, "retry_seconds": 0.5}
    audit = audit_of(parse_config(data))
    assert audit.fsync is FsyncPolicy.ALL and audit.retry_interval == 0.5
    assert audit.fsync_for(motion=False, ahead=False)  # all: outcomes too
    for key, value, rule in [
        ("fsync", "sometimes", "motion"),
        ("max_bytes", 10, "65536"),
        ("keep", 0, "1"),
    ]:
        with pytest.raises(ConfigError, match=rf"audit\.{key}") as caught:
            parse_config({**data, "audit": {key: value}})
        assert rule in str(caught.value)
