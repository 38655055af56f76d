"""Subscribers hear most replies once the next frame is out, but a motion's at once.

The poller withdraws its queued reads that a moving controller refuses (§10 EE: 動作中 ×,
the command error the gateway would then pin on the motion) when it hears the motion's '>'.
Heard one frame late, the read would already be on the wire: checked here on the
simulator's line log with a subscriber that withdraws a read the same way.
"""

from __future__ import annotations

import asyncio

from gateway.bus.events import BusEvent, ReplyObserved
from gateway.bus.read_back import is_motion
from gateway.bus.requests import Priority, TransactionResult
from gateway.protocol.command_text import parse
from tests.support.bus_rig import MakeBus


async def test_a_read_withdrawn_when_a_move_is_accepted_never_goes_out(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1")
    reads: list[asyncio.Future[TransactionResult]] = []

    def queue_read(event: BusEvent) -> None:
        # During the move's pre-reads of the position: a poll of EE queued behind the move.
        if isinstance(event, ReplyObserved) and event.command.wire() == "61" and not reads:
            submit = bus.scheduler.submit("1", parse("EE"), priority=Priority.POLL)
            reads.append(asyncio.ensure_future(submit))

    def withdraw(event: BusEvent) -> None:
        if isinstance(event, ReplyObserved) and is_motion(event.command) and reads:
            reads[0].cancel()

    bus.scheduler.events.subscribe(queue_read)
    bus.scheduler.events.subscribe(withdraw)
    result = await bus.scheduler.submit("1", [parse("21000"), parse("31")], motor=1)
    assert result.ok, result
    # The next frames are the scheduler's own or the test's status reads, never the EE.
    await bus.wait_idle()
    assert reads and reads[0].cancelled()
    assert "EE" not in bus.texts(), bus.texts()
