"""SUM1 set through the gateway, then lost by a reconnect's outage or by ``DL`` (§10 SUM, DL).

Both events are the gateway's to see: it forgets the framing at once and frames plain until it
reads it back, so no frame the controller, back on SUM0, would misread ever goes out: a
controller that kept SUM1 answers a plain frame '?' (not taken), never something else
(docs/manual-notes.md "Frames after the framing may have changed").
"""

from __future__ import annotations

import asyncio

from gateway.bus.events import LinkUp
from gateway.bus.requests import Outcome
from gateway.protocol.command_text import parse
from gateway.protocol.framing import POWER_ON, checksum
from gateway.sim.control import Controls
from tests.support.bus_rig import MakeBus


def summed(frame: bytes) -> bool:
    """``frame`` ends with the checksum of what comes before it (§10 SUM)."""
    return len(frame) >= 5 and frame[-3:-1] == checksum(frame[:-3])


async def test_a_controller_power_cycled_during_an_outage_hears_only_plain_frames(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1", reconnect_initial_real=0.01, reconnect_max_real=0.04)
    assert (await bus.scheduler.submit("1", parse("SUM1"))).outcome is Outcome.DONE
    assert await bus.query("1", "6") == 0
    assert bus.frames()[-1] == b"$168B\r"
    up = asyncio.Event()
    bus.scheduler.events.subscribe(lambda e: up.set() if isinstance(e, LinkUp) else None)
    bus.unplug()
    Controls(bus.sim).power_cycle("1")  # back on SUM0 (DW never ran)
    mark = len(bus.frames())
    bus.plug()
    await asyncio.wait_for(up.wait(), 10.0)
    assert bus.scheduler.framing("1") == POWER_ON
    move = await bus.scheduler.submit("1", [parse("2100"), parse("3")], motor=1)
    assert move.outcome is Outcome.DONE, move
    sent = bus.frames()[mark:]
    assert not [f for f in sent if summed(f)], sent
    assert b"$12100\r" in sent and sent[-1] == b"$13\r"
    await bus.wait_idle()
    assert bus.position() == 100


async def test_dl_that_loads_sum0_is_followed_by_plain_frames_only(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    assert (await bus.scheduler.submit("1", parse("SUM1"))).outcome is Outcome.DONE
    # DW never ran: DL loads the factory framing, SUM0 (§10 DL).
    loaded = await bus.scheduler.submit("1", parse("DL"))
    assert loaded.outcome is Outcome.DONE, loaded
    assert loaded.results[0].frame == b"$1DL" + checksum(b"$1DL") + b"\r"  # sent on SUM1
    mark = len(bus.frames())
    assert not bus.controller().framing.checksum
    move = await bus.scheduler.submit("1", [parse("2100"), parse("3")], motor=1)
    assert move.outcome is Outcome.DONE, move
    sent = bus.frames()[mark - 2 :]  # DL's own position read-backs (61, 62) included
    assert sent[:2] == [b"$161\r", b"$162\r"]
    assert not [f for f in sent if summed(f)], sent
    assert sent[-1] == b"$13\r"
    await bus.wait_idle()
    assert bus.position() == 100
