"""A keyed request's ``in progress`` record: on disk before the request acts, replaced by the
operation it starts or its response, taken away when it was answered without acting, and
still there after a reopen when neither was recorded (the process died in between)."""

from __future__ import annotations

from pathlib import Path

from gateway.service.store import StateStore
from gateway.service.store.records import (
    RequestKey,
    begin_key,
    drop_pending_key,
    insert_operation,
    load_key,
    save_response,
)

NOW = 1_000_000.0


def _key(name: str) -> RequestKey:
    return RequestKey.of(("client", name, "POST", "/controllers/stage/program/run"), "fp", NOW)


async def test_an_in_progress_key_outlives_a_reopen_with_its_fingerprint_and_time(
    tmp_path: Path,
) -> None:
    store = await StateStore.open(tmp_path / "state")
    key = _key("run-1")
    try:
        await store.run(lambda c: begin_key(c, key))
    finally:
        await store.close()
    store = await StateStore.open(tmp_path / "state")
    try:
        stored = await store.run(lambda c: load_key(c, key.ident, NOW + 5))
        assert stored is not None and stored.in_progress
        assert (stored.fingerprint, stored.created) == ("fp", NOW)
        assert stored.status is None and stored.operation is None
    finally:
        await store.close()


async def test_the_response_or_the_operation_replaces_in_progress() -> None:
    store = StateStore.memory()
    answered, moved = _key("answered"), _key("moved")
    try:
        await store.run(lambda c: begin_key(c, answered))
        await store.run(lambda c: save_response(c, answered, 200, [(b"x-a", b"1")], b"{}"))
        stored = await store.run(lambda c: load_key(c, answered.ident, NOW))
        assert stored is not None and not stored.in_progress
        assert (stored.status, stored.headers, stored.body) == (200, [(b"x-a", b"1")], b"{}")

        await store.run(lambda c: begin_key(c, moved))
        record = {"id": "op-1", "state": "sent", "created": NOW, "ended": None}
        await store.run(lambda c: insert_operation(c, 1, record, moved))
        stored = await store.run(lambda c: load_key(c, moved.ident, NOW))
        assert stored is not None and not stored.in_progress and stored.operation == "op-1"
    finally:
        await store.close()


async def test_dropping_takes_away_only_a_key_still_in_progress() -> None:
    store = StateStore.memory()
    pending, answered = _key("refused"), _key("answered")
    try:
        await store.run(lambda c: begin_key(c, pending))
        await store.run(lambda c: begin_key(c, answered))
        await store.run(lambda c: save_response(c, answered, 504, [], b"late"))
        await store.run(lambda c: drop_pending_key(c, pending))
        await store.run(lambda c: drop_pending_key(c, answered))
        assert await store.run(lambda c: load_key(c, pending.ident, NOW)) is None
        kept = await store.run(lambda c: load_key(c, answered.ident, NOW))
        assert kept is not None and kept.status == 504 and kept.body == b"late"
    finally:
        await store.close()


async def test_a_key_past_its_retention_is_begun_afresh() -> None:
    store = StateStore.memory()
    old = _key("reused")
    fresh = RequestKey(old.ident, "other", NOW + 90_000)
    try:
        await store.run(lambda c: begin_key(c, old))
        await store.run(lambda c: save_response(c, old, 200, [], b"old"))
        await store.run(lambda c: begin_key(c, fresh))
        stored = await store.run(lambda c: load_key(c, old.ident, NOW + 90_001))
        assert stored is not None and stored.in_progress
        assert (stored.fingerprint, stored.created, stored.body) == ("other", NOW + 90_000, b"")
    finally:
        await store.close()
