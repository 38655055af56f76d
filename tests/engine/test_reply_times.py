"""The time of a loop's latest reply crosses the worker channel: a poll that changes nothing
publishes no change, yet the API process's views must tell how old their reading is
(``updated``, the ``Age`` header, a metric's timestamp) as the cache of one process does.

The worker and its client on the test's event loop, joined by socketpairs (tests/engine/
conftest.py); the poller reads the simulated controller at rest.
"""

from __future__ import annotations

from gateway.bus.state_types import Change
from tests.support.engine_rig import Attach, MakeBus
from tests.support.state_waits import until_state

#: Real seconds to wait for a condition.
WAIT = 10.0


async def test_an_idle_poll_moves_the_mirrors_reply_time_without_a_change(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.proxy
    mirror, cache = linked.mirror, linked.cache
    await proxy.polling(True)

    def axis_updated() -> float | None:
        return mirror.axis(proxy.name, "1", 1).updated

    await until_state(mirror, lambda: axis_updated() is not None, WAIT)
    await until_state(mirror, lambda: not mirror.axis(proxy.name, "1", 1).stale, WAIT)
    first = axis_updated()
    assert first is not None
    published: list[Change] = []
    stop = cache.changes.subscribe(
        lambda change: published.append(change) if change.motor == 1 else None
    )
    try:
        # re-checked on every change of the mirror (the loop's counters: one a period)
        await until_state(mirror, lambda: (axis_updated() or 0.0) > first, WAIT)
    finally:
        stop()
    # no change told the axis's reply time meanwhile (a sensors' reading may have changed)
    assert [c for c in published if "updated" in c.values] == []
    worker_time = cache.axis(proxy.name, "1", 1).updated
    assert worker_time is not None and worker_time >= (axis_updated() or 0.0) > first
    assert mirror.axis(proxy.name, "1", 1).position == cache.axis(proxy.name, "1", 1).position
