"""Right after a start nothing is claimed before it is read, through the real serial path.

A gateway restarted while an axis moves: a new state cache on the scheduler (what a restart
leaves), the simulated controller still jogging. The first status read says a motor moves, not
which (§10 "", §10 F): both axes are unknown (``moving`` None), and neither is fresh while its
position was never read.
"""

from __future__ import annotations

from gateway.bus.state import StateCache
from gateway.protocol.command_text import parse
from tests.support.bus_rig import MakeBus


async def test_a_restarted_gateway_claims_nothing_of_a_moving_controller_before_reading_it(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", [parse("7")])  # the old gateway's jog, motor 1 (power-on)
    cache = StateCache()
    bus.scheduler.use_state(cache)  # the gateway restarted: it knows nothing
    loop = bus.scheduler.name
    for m in (1, 2):
        axis = cache.axis(loop, "1", m)
        assert (axis.moving, axis.position, axis.stale) == (None, None, True)
    assert cache.controller(loop, "1").moving is None

    status = await bus.query("1", "")
    assert status.moving  # the simulated motor still turns
    assert cache.controller(loop, "1").moving is True
    for m in (1, 2):
        axis = cache.axis(loop, "1", m)
        # Which motor moves is not known yet, and no position was read: unknown, stale.
        assert (axis.moving, axis.position, axis.stale) == (None, None, True), axis

    await bus.query("1", "61")
    one = cache.axis(loop, "1", 1)
    assert one.position is not None and one.stale is False
    assert cache.axis(loop, "1", 2).stale is True  # motor 2's position: still not read
    await bus.query("1", "9")  # the condition flags name the selected (moving) motor
    assert cache.axis(loop, "1", 1).moving is True
    assert cache.axis(loop, "1", 2).moving is False
    await bus.scheduler.stop("1", parse("S"))
