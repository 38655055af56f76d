"""Lost replies to motion and non-idempotent commands: read back, never sent blindly again.

The decisions on their own first (what a read-back means), then on the simulator: the move
whose reply was dropped happened exactly once and is reported DONE; a move answered '?' is
sent again; a move the device did not execute (EMS pressed) is reported NOT_DONE.
"""

from __future__ import annotations

import pytest

from gateway.bus.read_back import (
    motion_outcome,
    resendable,
    value_check,
    value_outcome,
)
from gateway.bus.requests import Outcome, ReplyKind
from gateway.protocol.command_text import parse
from gateway.protocol.reply_values import ErrorOutput, ErrorWatch, PortByte, StatusFlags
from gateway.sim.faults import FaultKind
from tests.support.bus_rig import MakeBus

STOPPED = StatusFlags()
MOVING = StatusFlags(moving=True)


@pytest.mark.parametrize(
    ("status", "before", "after", "outcome"),
    [
        (MOVING, 100, 100, Outcome.DONE),  # still running
        (STOPPED, 100, 1100, Outcome.DONE),  # ran and stopped
        (STOPPED, 100, 100, Outcome.NOT_DONE),  # never ran
        (None, 100, 100, Outcome.UNKNOWN),  # status read failed
        (STOPPED, None, 100, Outcome.UNKNOWN),  # pre-read failed
        (StatusFlags(moving=True, command_error=True), 100, 900, Outcome.UNKNOWN),
    ],
)
def test_what_a_motion_read_back_means(
    status: StatusFlags | None, before: int | None, after: int | None, outcome: Outcome
) -> None:
    assert motion_outcome(status, before, after) is outcome


def test_what_a_setting_read_back_means() -> None:
    check = value_check(parse("OHI100"))
    assert check is not None and check.query.wire() == "OH"
    assert value_outcome(5000, 5100, check) is Outcome.DONE
    assert value_outcome(5000, 5000, check) is Outcome.NOT_DONE
    assert value_outcome(5000, 4000, check) is Outcome.UNKNOWN  # someone else changed it
    assert value_outcome(None, 5100, check) is Outcome.UNKNOWN
    # §10 OH: 1-16,383; a result outside is refused and the value stays
    assert value_outcome(16300, 16300, check) is Outcome.DONE
    down = value_check(parse("OSD300"))
    assert down is not None and down.query.wire() == "OS"
    assert down.expected(300) == 300 and down.expected(1000) == 700
    k1 = value_check(parse("K3,A5"))  # §10 K form I: DT 3, outputs A5
    assert k1 is not None and k1.expected(ErrorOutput()) == ErrorOutput(
        ErrorWatch(3), PortByte(0xA5)
    )
    k2 = value_check(parse("K2,7"))  # form II: one output bit
    assert k2 is not None and k2.expected(ErrorOutput()) == ErrorOutput(
        ErrorWatch.EMERGENCY_STOP, PortByte.of(7)
    )
    assert value_check(parse("T100")) is None


def test_which_commands_may_be_sent_again() -> None:
    assert resendable(parse("OH4000"))  # an absolute setting
    assert resendable(parse("6"))  # a query that clears nothing
    assert resendable(parse("SS"))  # a stop
    assert not resendable(parse("4"))  # motion
    assert not resendable(parse("OHI10"))  # increment
    assert not resendable(parse(""))  # clears the error bits it reports (§10 "")
    assert not resendable(parse("DW"))  # an EEPROM write


async def test_a_move_whose_reply_was_lost_is_not_sent_again_and_is_done(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("21000"))  # §10 2: the pulse count of 4 and 5
    # The pre-read 62 (twice) goes out right before the move: the next frame is the move.
    bus.once_after("62", lambda: bus.fault(FaultKind.DROP), nth=2)
    result = await bus.scheduler.submit("1", parse("42"))
    move = result.results[0]
    assert move.kind is ReplyKind.TIMEOUT
    assert move.outcome is Outcome.DONE
    assert move.seen["position_before"] == 0
    assert bus.texts().count("42") == 1  # never sent again
    await bus.wait_idle()
    assert bus.position(motor=2) == 1000  # moved once, not twice
    assert bus.scheduler.snapshot().verifications == 1
    # The read-back's status read is "" (it clears the error bits: published, notes).
    assert bus.texts()[1:6] == ["62", "62", "42", "", "62"]


async def test_a_move_answered_not_accepted_is_sent_again(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("2500"))
    bus.once_after("61", lambda: bus.fault(FaultKind.NAK), nth=2)
    result = await bus.scheduler.submit("1", parse("41"))
    assert result.outcome is Outcome.DONE
    assert result.results[0].attempts == 2
    assert bus.texts().count("41") == 2  # '?': the controller did not take it (§9-2)
    await bus.wait_idle()
    assert bus.position(motor=1) == 500


async def test_a_move_the_device_did_not_run_is_not_done(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("2500"))
    bus.sim.act(lambda now: bus.controller().set_ems(now, True))
    bus.once_after("61", lambda: bus.fault(FaultKind.DROP), nth=2)
    result = await bus.scheduler.submit("1", parse("41"))
    move = result.results[0]
    # EMS ON: the move is answered '>' and not run (notes "Motion commands while EMS is ON")
    assert move.outcome is Outcome.NOT_DONE
    status = move.seen["status"]
    assert isinstance(status, StatusFlags) and status.emergency_stop and not status.moving
    assert bus.position(motor=1) == 0


async def test_a_lost_increment_is_read_back_not_repeated(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    bus.once_after("OH", lambda: bus.fault(FaultKind.DROP))
    result = await bus.scheduler.submit("1", parse("OHI100"), motor=1)
    step = result.results[0]
    assert step.outcome is Outcome.DONE
    assert (step.seen["value_before"], step.seen["value_after"]) == (5000, 5100)
    assert bus.texts().count("OHI100") == 1
    assert bus.controller().settings.motors[1].oh == 5100  # §16 5000, incremented once


async def test_the_rest_of_a_transaction_is_skipped_after_a_failure(make_bus: MakeBus) -> None:
    bus = await make_bus("1", nak_retries=0)
    await bus.scheduler.submit("1", parse("EL0"))  # the framing is known: '?' is noise
    bus.fault(FaultKind.NAK)
    result = await bus.scheduler.submit("1", [parse("OH4000"), parse("OL400")])
    assert [r.kind for r in result.results] == [ReplyKind.NOT_ACCEPTED, ReplyKind.SKIPPED]
    assert result.outcome is Outcome.NOT_DONE
    assert "OL400" not in bus.texts()
