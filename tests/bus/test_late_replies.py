"""Late replies: after a time-out the line is brought back in step before a reply is trusted
again (DESIGN invariant 13), on the simulator through the in-process pipe.

A late reply is the simulator's ``late`` fault: the controller executes the frame and its
reply leaves ``delay`` device seconds later than normal. The line runs at real time (scale 1):
the windows are a few character times of the line, not host latency. Every assertion is about
what a user of the line notices: the values the callers got.
"""

from __future__ import annotations

import pytest

from gateway.bus.lateness import CAP, MARGIN, MOST, Lateness
from gateway.bus.requests import Outcome
from gateway.bus.timing import Timing
from gateway.protocol.command_text import parse
from gateway.sim.faults import FaultKind
from tests.support.bus_rig import MakeBus

#: No resend of a lost read: the next frame is another command, as when clients queue reads.
NO_RESEND = {"resend_retries": 0}


async def test_a_reply_later_than_its_own_window_is_not_the_next_reads_value(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1", scale=1.0, **NO_RESEND)
    await bus.scheduler.submit("1", [parse("A0091111"), parse("A0102222")])
    timing = bus.scheduler.timing
    # Entry 9's reply begins ~95 ms after its frame: after its time-out (~51 ms) and the quiet
    # period of its own reply (~43 ms), where the next frame used to go out; inside the
    # silence of the loop's longest reply (~73 ms). Entry 10's reply is a little slow too.
    assert timing.real(timing.reply_timeout(8, 12)) + timing.late_quiet(12) < 0.095
    assert timing.real(timing.reply_timeout(8, 12)) + timing.resync_quiet() > 0.11
    bus.fault(FaultKind.LATE, delay=0.095)
    bus.fault(FaultKind.LATE, delay=0.030)
    before = bus.scheduler.snapshot()
    nine = await bus.scheduler.submit("1", parse("A009D"))
    ten = await bus.scheduler.submit("1", parse("A010D"))
    assert nine.value == 1111 and nine.results[0].late  # its own reply, late
    assert ten.value == 2222  # never entry 9's
    after = bus.scheduler.snapshot()
    assert after.late_replies - before.late_replies >= 1  # counted, and dropped or kept


async def test_a_reply_that_does_not_fit_its_form_is_a_line_error_never_a_value(
    make_bus: MakeBus,
) -> None:
    bus = await make_bus("1", scale=1.0, **NO_RESEND)
    await bus.scheduler.submit("1", [parse("A0093333"), parse("A0104444")])
    # The status read's reply ('>$1' 1 digit CR) comes so late that it meets the entry read
    # behind it; the entry's own reply (8 digits) is late as well, and meets whatever follows.
    bus.fault(FaultKind.LATE, delay=0.2)
    bus.fault(FaultKind.LATE, delay=0.1)
    status = await bus.scheduler.submit("1", parse(""))
    nine = await bus.scheduler.submit("1", parse("A009D"))
    ten = await bus.scheduler.submit("1", parse("A010D"))
    assert status.value is None  # lost, read again by whoever needs it
    assert nine.value in (None, 3333)  # a status digit is not an entry
    assert nine.outcome is not Outcome.DONE or nine.value == 3333
    assert ten.value == 4444  # never entry 9's, come late
    assert bus.scheduler.resync_figures()[0] >= 2  # after the time-out and the misfit


async def test_a_clean_line_never_waits_for_a_resync(make_bus: MakeBus) -> None:
    bus = await make_bus("12")
    for body in "12":
        await bus.scheduler.submit(body, [parse("A0015555"), parse("OH4000")], motor=2)
        await bus.scheduler.submit(body, [parse("21500"), parse("31")], motor=1)  # to 1,500
        await bus.wait_idle(body)
        for text in ("A001D", "OH", "61", "62", "", "97", "V"):
            assert (await bus.scheduler.submit(body, parse(text), motor=2)).ok
    assert bus.position("1", 1) == bus.position("2", 1) == 1500
    assert bus.scheduler.resync_figures()[0] == 0
    assert bus.scheduler.snapshot().late_replies == 0


def test_the_resync_waits_longer_on_a_line_that_has_shown_late_replies() -> None:
    timing = Timing(9600)
    base = timing.resync_quiet()
    lateness = Lateness()
    assert lateness.quiet(base) == base  # nothing seen: the longest reply of the loop
    lateness.arrived(5.0)  # no time-out yet: nothing to measure from
    assert lateness.quiet(base) == base
    lateness.timed_out(10.0)
    lateness.arrived(10.0 + base)  # a reply came as late as the whole silence
    assert lateness.quiet(base) == pytest.approx(MARGIN * base)
    lateness.arrived(10.0 + 5 * CAP)  # far too late to be a reply: not learnt
    assert lateness.quiet(base) == pytest.approx(MARGIN * base)
    lateness.arrived(10.0 + CAP / 2)  # a stray long after: the silence grows, but not far
    assert lateness.quiet(base) == pytest.approx(MOST * base)
    for _ in range(200):  # silent resyncs: back to the base
        lateness.silent()
    assert lateness.quiet(base) == base
