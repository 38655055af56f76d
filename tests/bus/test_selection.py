"""Motor selection (§9-1, §10 F): F goes first when needed, never trusted after doubt.

The concurrency test checks, at the moment each transaction ends, that the simulated
controller holds every setting on the motor it was meant for.
"""

from __future__ import annotations

import asyncio
import random

import pytest

from gateway.bus.events import SelectionChanged, TransactionDone
from gateway.bus.requests import DeadlineExpired, Outcome, ReplyKind
from gateway.bus.selection import after_accepted, needs_selection, selection_from_reply
from gateway.bus.state import StateCache
from gateway.protocol import commands as cmd
from gateway.protocol.command_text import parse
from gateway.protocol.framing import Framing
from gateway.protocol.reply_values import ConditionFlags
from gateway.sim.faults import FaultKind, FaultRule
from tests.support.bus_rig import MakeBus


def test_which_commands_need_the_selection() -> None:
    assert needs_selection(parse("OH4000"))  # per motor (§10 F list)
    assert needs_selection(parse("4"))  # motion on the selected motor
    assert not needs_selection(parse("42"))  # the suffix says which (§9-1)
    assert not needs_selection(parse("62"))  # a query with its motor (§10 F)
    assert not needs_selection(parse("S"))  # stops act on the moving = selected motor
    assert not needs_selection(parse(""))  # the controller's status
    assert not needs_selection(parse("2500"))  # shared position data (§10 2)


def test_what_replies_tell_of_the_selection() -> None:
    # §10 9: bit 7 = selected motor; '>$19A' is motor 2 (bit 7 set)
    assert selection_from_reply(parse("9"), ConditionFlags.from_byte(0x9A)) == 2
    assert selection_from_reply(parse("97"), 0) == 1
    assert selection_from_reply(parse("97"), 1) == 2
    assert selection_from_reply(parse("96"), 1) is None  # another bit
    assert selection_from_reply(parse("F"), 2) == 2


def test_a_motion_suffix_selects_only_when_er1_says_it_ran() -> None:
    # Without ER1 a refused move also gets '>' and keeps the old selection: not known.
    assert after_accepted(parse("42"), Framing()) is None
    assert after_accepted(parse("42"), Framing(error_mark=True)) == 2
    assert after_accepted(parse("OH100"), Framing()) is False


async def test_f_goes_first_only_when_the_selection_differs(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("OH4000"), motor=2)
    await bus.scheduler.submit("1", parse("OL400"), motor=2)
    await bus.scheduler.submit("1", parse("OS200"), motor=1)
    assert bus.texts() == ["F2", "97", "OH4000", "OL400", "F1", "97", "OS200"]
    motors = bus.controller().settings.motors
    assert (motors[2].oh, motors[2].ol, motors[1].os) == (4000, 400, 200)
    assert (motors[1].oh, motors[1].ol, motors[2].os) == (5000, 500, 300)  # §16 defaults


async def test_the_selection_is_dropped_after_doubt(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("OH4000"), motor=2)
    bus.fault(FaultKind.DROP)  # the reply to the next frame is lost: doubt
    await bus.scheduler.submit("1", parse("A000D"))
    assert bus.scheduler.selected_motor("1") is None
    await bus.scheduler.submit("1", parse("OL400"), motor=2)
    bus.fault(FaultKind.NAK)  # '?' is doubt too (DESIGN invariant 5)
    await bus.scheduler.submit("1", parse("A000D"))
    await bus.scheduler.submit("1", parse("OS200"), motor=2)
    texts = bus.texts()
    assert texts == [
        "F2", "97", "OH4000",
        "A000D", "A000D",  # sent again after the lost reply
        "F2", "97", "OL400",  # F again
        "A000D", "A000D",
        "F2", "97", "OS200",
    ]  # fmt: skip
    changes = [e.motor for e in bus.events if isinstance(e, SelectionChanged)]
    assert changes == [2, None, 2, None, 2]


async def test_f_refused_while_a_motor_moves_keeps_the_setting_off_the_wrong_motor(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("7"), motor=1)  # jog motor 1 (§10 7)
    # The state cache knows motor 1 moves: a motor-2 setting waits (its deadline bounds it)
    # rather than send an F the controller would refuse.
    with pytest.raises(DeadlineExpired):
        await bus.scheduler.submit("1", parse("OH4000"), motor=2, deadline=0.3)
    assert "F2" not in bus.texts()
    # A cache that never heard of the jog (a gateway started while the motor turns): F2 goes
    # out, is refused (§10 F), and 97 shows motor 1 still selected.
    bus.scheduler.use_state(StateCache())
    result = await bus.scheduler.submit("1", parse("OH4000"), motor=2)
    assert result.outcome is Outcome.NOT_DONE
    assert result.results[0].kind is ReplyKind.SKIPPED
    assert bus.texts()[-2:] == ["F2", "97"]
    assert "OH4000" not in bus.texts()
    assert bus.controller().settings.motors[1].oh == 5000
    await bus.scheduler.stop("1", cmd.slow_stop())
    await bus.wait_idle()


async def test_motor_2_settings_never_land_on_motor_1_under_concurrent_callers(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1")
    for kind, p in ((FaultKind.NAK, 0.05), (FaultKind.DROP, 0.03)):
        bus.sim.faults.add(FaultRule(kind, probability=p))
    rng = random.Random(4)
    wrong: list[str] = []
    checked: list[int] = []

    def check(event: object) -> None:
        # Right when a transaction ends, the controller holds what it set, on its motor, and
        # the other motor holds a value of its own range (or the §16 default).
        if isinstance(event, TransactionDone) and event.outcome is Outcome.DONE:
            assert event.motor is not None
            oh, ol = (int(c.wire()[2:]) for c in event.commands)
            motors = bus.controller().settings.motors
            other = motors[3 - event.motor]
            if (motors[event.motor].oh, motors[event.motor].ol) != (oh, ol):
                wrong.append(f"{event.commands} not on motor {event.motor}")
            if other.oh != 5000 and other.oh // 1000 != 3 - event.motor:
                wrong.append(f"{event.commands}: motor {3 - event.motor} has OH {other.oh}")
            checked.append(event.motor)

    bus.scheduler.events.subscribe(check)

    async def caller(n: int) -> None:
        motor = 1 + n % 2
        # motor 1 values 1001-1999, motor 2 values 2001-2999: a mix-up shows
        oh = motor * 1000 + rng.randrange(1, 999)
        ol = motor * 100 + rng.randrange(1, 99)
        result = await bus.scheduler.submit("1", [parse(f"OH{oh}"), parse(f"OL{ol}")], motor=motor)
        assert result.outcome is not Outcome.NOT_DONE or result.results[0].kind in (
            ReplyKind.NOT_ACCEPTED,
            ReplyKind.SKIPPED,
        )

    await asyncio.gather(*(caller(n) for n in range(60)))
    assert wrong == []
    assert checked.count(1) > 20 and checked.count(2) > 20
    motors = bus.controller().settings.motors
    assert 1000 < motors[1].oh < 2000 and 2000 < motors[2].oh < 3000
    assert 100 < motors[1].ol < 200 and 200 < motors[2].ol < 300
