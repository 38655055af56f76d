"""The state store: SQLite in the state directory, durable settings, one gateway per directory,
the rows of operations and keys, their retention, the counters across a reopen."""

from __future__ import annotations

import sqlite3
from pathlib import Path
from typing import Any

import pytest

from gateway.service.config import ConfigError
from gateway.service.store import StateStore, default_state_dir
from gateway.service.store.records import (
    KEY_RETENTION,
    OPERATION_RETENTION,
    RequestKey,
    insert_operation,
    load_key,
    load_operations,
    purge,
    save_operation,
    save_response,
)


def _record(
    ident: str, created: float, state: str = "sent", ended: float | None = None
) -> dict[str, Any]:
    return {"id": ident, "state": state, "created": created, "ended": ended, "axis": "m.1.1"}


async def test_the_database_is_durable_and_the_directory_private(tmp_path: Path) -> None:
    store = await StateStore.open(tmp_path / "state")
    try:
        modes = await store.run(
            lambda c: (
                c.execute("PRAGMA journal_mode").fetchone()[0],
                c.execute("PRAGMA synchronous").fetchone()[0],
            )
        )
        assert modes == ("wal", 2)  # 2: FULL
        assert (tmp_path / "state" / "state.sqlite3").is_file()
        assert (tmp_path / "state").stat().st_mode & 0o777 == 0o700
    finally:
        await store.close()


async def test_a_second_gateway_on_the_same_directory_is_refused(tmp_path: Path) -> None:
    first = await StateStore.open(tmp_path / "state")
    try:
        with pytest.raises(ConfigError, match=r"state_dir .*state: .*in use by another gateway"):
            await StateStore.open(tmp_path / "state")
    finally:
        await first.close()
    again = await StateStore.open(tmp_path / "state")  # released at close
    await again.close()


async def test_an_operation_and_its_key_are_written_together_and_read_back(
    tmp_path: Path,
) -> None:
    key = RequestKey.of(("client", "K-1", "POST", "/api/v1/axes/x/move"), "fp", 1000.0)
    store = await StateStore.open(tmp_path / "state")
    await store.run(lambda c: insert_operation(c, 41, _record("op-41-1", 1000.0), key))
    moved = _record("op-41-1", 1000.0, "done", 1002.0) | {"position": 3000}
    store.post(lambda c: save_operation(c, moved))  # queued: a later run sees it
    await store.close()

    store = await StateStore.open(tmp_path / "state")
    try:
        assert store.counters["operation"] == 41
        stored = await store.run(lambda c: load_key(c, key.ident, 1001.0))
        assert stored is not None and stored.operation == "op-41-1" and stored.status is None
        assert stored.fingerprint == "fp"
        (op,) = await store.run(lambda c: load_operations(c, 10))
        assert op["state"] == "done" and op["position"] == 3000
        # the response is kept beside the operation it started
        headers = [(b"location", b"/api/v1/operations/op-41-1")]
        await store.run(lambda c: save_response(c, key, 202, headers, b'{"id":"op-41-1"}'))
        stored = await store.run(lambda c: load_key(c, key.ident, 1001.0))
        assert stored is not None and stored.operation == "op-41-1"
        assert (stored.status, stored.headers, stored.body) == (202, headers, b'{"id":"op-41-1"}')
        # past its time a key answers nothing
        assert await store.run(lambda c: load_key(c, key.ident, 1000.0 + KEY_RETENTION)) is None
    finally:
        await store.close()


async def test_a_failed_insert_leaves_neither_the_operation_nor_the_key(tmp_path: Path) -> None:
    key = RequestKey.of(("c", "K", "POST", "/p"), "fp", 1.0)
    store = await StateStore.open(tmp_path / "state")
    try:
        await store.run(lambda c: insert_operation(c, 1, _record("op-1", 1.0), None))
        with pytest.raises(sqlite3.IntegrityError):  # the same id again
            await store.run(lambda c: insert_operation(c, 2, _record("op-1", 2.0), key))
        assert await store.run(lambda c: load_key(c, key.ident, 2.0)) is None
        assert store.counters.get("operation") is None  # the cache is the one read at open
        number = await store.run(
            lambda c: c.execute("SELECT value FROM counters WHERE name='operation'").fetchone()
        )
        assert number == (1,)
    finally:
        await store.close()


async def test_retention_drops_old_ends_and_keys_and_keeps_what_never_ended(
    tmp_path: Path,
) -> None:
    now = 10 * OPERATION_RETENTION
    old = now - OPERATION_RETENTION - 1
    store = await StateStore.open(tmp_path / "state")
    try:
        await store.run(lambda c: insert_operation(c, 1, _record("op-1", old, "done", old), None))
        await store.run(lambda c: insert_operation(c, 2, _record("op-2", old), None))
        await store.run(lambda c: insert_operation(c, 3, _record("op-3", now, "done", now), None))
        for number, when in ((1, now - KEY_RETENTION - 1), (2, now - 5)):
            key = RequestKey.of(("c", f"K{number}", "POST", "/p"), "fp", when)
            await store.run(lambda c, k=key: save_response(c, k, 200, [], b"{}"))
        assert await store.run(lambda c: purge(c, now)) == (1, 1)
        kept = [op["id"] for op in await store.run(lambda c: load_operations(c, 10))]
        assert kept == ["op-2", "op-3"]
        # the newest ``limit`` and every one not ended
        assert [op["id"] for op in await store.run(lambda c: load_operations(c, 1))] == [
            "op-2",
            "op-3",
        ]
    finally:
        await store.close()


async def test_counters_survive_a_reopen(tmp_path: Path) -> None:
    store = await StateStore.open(tmp_path / "state")
    await store.set_counter("sparkplug_bdseq", 17)
    await store.close()
    store = await StateStore.open(tmp_path / "state")
    assert store.counters["sparkplug_bdseq"] == 17
    await store.close()


async def test_a_newer_schema_is_refused_naming_the_directory(tmp_path: Path) -> None:
    (tmp_path / "state").mkdir()
    with sqlite3.connect(tmp_path / "state" / "state.sqlite3") as connection:
        connection.execute("PRAGMA user_version = 99")
    with pytest.raises(ConfigError, match="schema version 99 is newer"):
        await StateStore.open(tmp_path / "state")
    # the refused open let go of the directory
    with sqlite3.connect(tmp_path / "state" / "state.sqlite3") as connection:
        connection.execute("PRAGMA user_version = 1")
    store = await StateStore.open(tmp_path / "state")
    await store.close()


def test_the_default_directory_follows_systemd_then_xdg() -> None:
    assert default_state_dir({"STATE_DIRECTORY": "/var/lib/rc233-gateway"}) == Path(
        "/var/lib/rc233-gateway"
    )
    assert default_state_dir({"XDG_STATE_HOME": "/home/op/.state"}) == Path(
        "/home/op/.state/rc233-gateway"
    )
