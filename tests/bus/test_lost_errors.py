"""Error bits a lost reply cleared are read from the controller's second store.

``""`` clears its error bits when it answers (§10 "" 注意点); the controller keeps the same
bits in the store ``9`` form I reads and clears (§10 9 ③). When the reply to one is lost, the
scheduler reads the other at once, so an EMS or a limit error is never lost with a reply; and
an error both stores report is latched once, not twice.
"""

from __future__ import annotations

from gateway.bus.state import ErrorKind, StateCache
from gateway.protocol.registry import parse
from gateway.sim.faults import FaultKind
from tests.bus.conftest import MakeBus

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
