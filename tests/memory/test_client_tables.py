"""Tables keyed by a client (its address, its token) hold the clients of now, not of the past."""

from __future__ import annotations

from typing import Any

from gateway.api.auth_failures import BACKOFF_MAX, FORGET_AFTER, FREE_FAILURES, AuthFailures
from gateway.api.middleware.idempotency import MEMORY_KEYS, IdempotencyStore
from tests.support.fake_clock import FakeClock


def test_addresses_that_failed_long_ago_are_forgotten() -> None:
    clock = FakeClock()
    records: list[dict[str, Any]] = []
    failures = AuthFailures(records.append, clock=clock, capacity=4096, interval=0.0)
    for i in range(1_000):  # a scan: one wrong token from each of 1,000 addresses
        failures.failed(f"10.0.{i // 256}.{i % 256}", "GET /x", guessed=True)
    assert len(failures) == 1_000
    clock.now += FORGET_AFTER + 1
    failures.failed("192.0.2.9", "GET /x", guessed=True)  # the next failure sweeps the old
    assert len(failures) == 1
    assert sum(r["count"] for r in records) == 1_001  # each one written before it went


def test_an_address_still_blocked_or_still_to_be_written_is_kept() -> None:
    clock = FakeClock()
    records: list[dict[str, Any]] = []
    failures = AuthFailures(records.append, clock=clock, interval=FORGET_AFTER * 10)
    for _ in range(FREE_FAILURES + 20):  # blocked for the longest wait
        failures.failed("192.0.2.1", "GET /x", guessed=True)
    clock.now += FORGET_AFTER + 1
    failures.failed("192.0.2.2", "GET /x", guessed=True)
    # its count not written yet (one record an interval): it stays to be written
    assert len(failures) == 2
    assert failures.retry_after("192.0.2.1") is None  # the wait itself is over
    assert BACKOFF_MAX < FORGET_AFTER


async def test_keys_chosen_by_clients_stay_at_their_bound_in_memory() -> None:
    store = IdempotencyStore(clock=FakeClock())
    assert store.capacity == MEMORY_KEYS == 1_000  # the recent retries; the rest on disk
    for n in range(3 * MEMORY_KEYS):
        store.begin(("token", f"key-{n}", "POST", "/api/v1/axes/x/move"), "fingerprint")
    assert len(store) == MEMORY_KEYS
