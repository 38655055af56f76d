"""What a reply lost or bent on the line must not cost: an error, or a motion run twice.

Error bits a lost reply cleared are read from the controller's second store.

``""`` clears its error bits when it answers (§10 "" 注意点); the controller keeps the same
bits in the store ``9`` form I reads and clears (§10 9 ③). When the reply to one is lost, the
scheduler reads the other at once, so an EMS or a limit error is never lost with a reply; and
an error both stores report is latched once, not twice. A '?' to a motion command may be a
'>' one bit off (0x3E, 0x3F): the motion is sent again only when a read-back shows it did not
run (DESIGN invariant 6).
"""

from __future__ import annotations

import random
from typing import Any

from gateway.bus.requests import Outcome
from gateway.bus.state import ErrorKind, StateCache
from gateway.protocol.command_text import parse
from gateway.sim.faults import FaultKind
from tests.support.bus_rig import MakeBus

LOOP = "loop"


async def test_an_ems_whose_status_reply_was_lost_is_latched_at_once(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    state = StateCache()
    bus.scheduler.use_state(state)
    assert (await bus.scheduler.submit("1", parse(""))).ok  # first contact: no error
    mark = len(bus.texts())
    bus.sim.act(lambda now: bus.controller("1").set_ems(now, True))
    bus.fault(FaultKind.DROP, body="1")
    result = await bus.scheduler.submit("1", parse(""))
    assert not result.ok  # the reply was lost: the status itself is not known ...
    # ... but the EMS it cleared on the device was read from the other store, at once.
    assert bus.texts()[mark:] == ["", "9"]
    assert ErrorKind.EMERGENCY in state.controller(LOOP, "1").latched
    assert state.axis(LOOP, "1", 1).emergency
    assert "9" in result.results[0].note


async def test_an_error_both_stores_report_is_latched_once(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    state = StateCache()
    bus.scheduler.use_state(state)
    bus.sim.act(lambda now: bus.controller("1").set_ems(now, True))
    assert (await bus.scheduler.submit("1", parse(""))).ok
    assert state.controller(LOOP, "1").latched[ErrorKind.EMERGENCY].count == 1
    now = bus.scheduler.clock()
    assert state.acknowledge(LOOP, "1", now) == [ErrorKind.EMERGENCY]
    # The form I read reports the same EMS from its own store: not a new one.
    assert (await bus.scheduler.submit("1", parse("9"))).ok
    assert ErrorKind.EMERGENCY not in state.controller(LOOP, "1").latched


class _FirstBit(random.Random):
    """A line-noise source that always flips bit 0 of the first byte: '>' becomes '?'."""

    def randrange(self, *args: Any, **kwargs: Any) -> int:
        return 0


async def test_a_garbled_ack_that_reads_as_nak_never_moves_a_motor_twice(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1")
    start = bus.position("1", 1)
    bus.sim.faults.rng = _FirstBit()
    # The controller takes the move; its '>' (0x3E) reaches the host one bit off: '?' (0x3F).
    bus.once_after("61", lambda: bus.fault(FaultKind.GARBLE, body="1"), nth=2)
    result = await bus.scheduler.submit("1", [parse("2300"), parse("41")])
    await bus.wait_idle()
    assert bus.position("1", 1) == start + 300  # once, not twice
    assert bus.texts().count("41") == 1
    move = result.results[1]
    assert move.outcome is Outcome.DONE, move
    assert move.seen["position_before"] == start
