"""The state cache on its own: hand-made replies in, latched state and numbered changes out.

Reply texts are the manual's own examples where it has them (§10 "" (I)-(III), §10 9 '>$19A'),
decoded with the protocol's reply decoder, as the scheduler hands them over.
"""

from __future__ import annotations

from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import FramingChanged, LinkDown, LinkUp, ReplyObserved, TransactionDone
from gateway.bus.requests import Outcome, Priority
from gateway.bus.state import (
    Change,
    ErrorKind,
    StateCache,
)
from gateway.protocol.command_text import parse
from gateway.protocol.framing import Framing
from gateway.protocol.replies import decode_reply
from gateway.protocol.reply_values import ProgramState
from tests.support.state_replies import LOOP, reply


def test_an_error_a_read_cleared_stays_until_acknowledged() -> None:
    cache = StateCache()
    # §10 "" (III): '>$1A' = command error and limit error, motor stopped.
    reply(cache, "", "A", 1.0)
    # The read cleared bits 1-3 on the device: the next read says '>$10' (§10 "" (I)).
    reply(cache, "", "0", 2.0)
    reply(cache, "", "0", 3.0)
    ctl = cache.controller(LOOP, "1")
    assert set(ctl.latched) == {ErrorKind.LIMIT, ErrorKind.COMMAND}
    assert ctl.status is not None and not ctl.status.has_error  # the device's view: cleared
    assert ctl.latched[ErrorKind.LIMIT].first == 1.0 and ctl.latched[ErrorKind.LIMIT].count == 1
    assert cache.axis(LOOP, "1", 1).command_error and cache.axis(LOOP, "1", 2).command_error

    assert set(cache.acknowledge(LOOP, "1", 4.0)) == {ErrorKind.LIMIT, ErrorKind.COMMAND}
    assert cache.controller(LOOP, "1").latched == {}
    assert not cache.axis(LOOP, "1", 1).command_error


def test_the_same_error_read_again_counts_on_the_same_latch() -> None:
    cache = StateCache()
    reply(cache, "", "8", 1.0)  # command error
    reply(cache, "", "8", 2.0)  # another one before anybody acknowledged
    latch = cache.controller(LOOP, "1").latched[ErrorKind.COMMAND]
    assert (latch.first, latch.last, latch.count, latch.source) == (1.0, 2.0, 2, '""')


def test_a_limit_error_goes_to_the_motor_that_moved() -> None:
    cache = StateCache()
    reply(cache, "2100", None, 0.5)
    reply(cache, "32", None, 1.0)  # '3' with motor 2: selects motor 2 and moves it (§9-1)
    reply(cache, "", "1", 1.1)  # moving
    assert cache.axis(LOOP, "1", 2).moving and not cache.axis(LOOP, "1", 1).moving
    reply(cache, "", "2", 1.5)  # stopped, limit error
    assert cache.axis(LOOP, "1", 2).limit_error
    assert not cache.axis(LOOP, "1", 1).limit_error
    assert not cache.axis(LOOP, "1", 2).moving
    # Acknowledging on the other axis changes nothing; on motor 2 it clears the controller.
    assert cache.acknowledge(LOOP, "1", 2.0, motor=1) == []
    assert cache.acknowledge(LOOP, "1", 2.0, motor=2) == [ErrorKind.LIMIT]
    assert ErrorKind.LIMIT not in cache.controller(LOOP, "1").latched


def test_an_emergency_stop_shows_on_both_axes_until_each_acknowledges() -> None:
    cache = StateCache()
    reply(cache, "", "4", 1.0)  # bit 2: EMS input was ON
    assert cache.axis(LOOP, "1", 1).emergency and cache.axis(LOOP, "1", 2).emergency
    assert cache.acknowledge(LOOP, "1", 2.0, motor=1) == []
    assert not cache.axis(LOOP, "1", 1).emergency and cache.axis(LOOP, "1", 2).emergency
    assert cache.acknowledge(LOOP, "1", 3.0, motor=2) == [ErrorKind.EMERGENCY]
    assert cache.controller(LOOP, "1").latched == {}


def test_condition_flags_form_one_latch_and_tell_mode_and_motor() -> None:
    cache = StateCache()
    # §10 9: '>$19A' = command and limit error, mode 1, motor 2 selected.
    reply(cache, "9", "9A", 1.0)
    ctl = cache.controller(LOOP, "1")
    assert set(ctl.latched) == {ErrorKind.LIMIT, ErrorKind.COMMAND}
    assert (ctl.mode, ctl.selected_motor, ctl.selection_confirmed) == (1, 2, True)
    assert cache.axis(LOOP, "1", 2).selected and not cache.axis(LOOP, "1", 1).selected
    assert cache.axis(LOOP, "1", 2).limit_error and not cache.axis(LOOP, "1", 1).limit_error


def test_a_communication_error_read_with_90_latches_once_per_occurrence() -> None:
    cache = StateCache()
    reply(cache, "90", "1", 1.0)
    assert ErrorKind.COMMUNICATION in cache.controller(LOOP, "1").latched
    cache.acknowledge(LOOP, "1", 2.0)
    # 90 clears nothing (§10 9 ②): the same set bit is the same error, not a new one.
    reply(cache, "90", "1", 3.0)
    assert cache.controller(LOOP, "1").latched == {}
    # Someone read 9 form I (cleared bits 0-3); a new error shows as 1 again: latched.
    reply(cache, "9", "00", 4.0)
    reply(cache, "90", "1", 5.0)
    assert cache.controller(LOOP, "1").latched[ErrorKind.COMMUNICATION].first == 5.0


def test_a_communication_error_is_acknowledged_on_the_controller_only() -> None:
    cache = StateCache()
    reply(cache, "9", "01", 1.0)
    assert cache.acknowledge(LOOP, "1", 2.0, motor=1) == []
    assert cache.acknowledge(LOOP, "1", 2.0, kinds=[ErrorKind.COMMUNICATION]) == [
        ErrorKind.COMMUNICATION
    ]


def test_a_program_error_read_with_gss_stays_latched() -> None:
    cache = StateCache()
    reply(cache, "GSS", "E", 1.0)  # §10 GSS example: '>$1E', then '>$10'
    reply(cache, "GSS", "0", 2.0)
    ctl = cache.controller(LOOP, "1")
    assert ctl.program is ProgramState.ENDED
    assert ErrorKind.PROGRAM in ctl.latched


def test_positions_and_sensors_go_to_their_axis() -> None:
    cache = StateCache()
    reply(cache, "61", "00003500", 1.0)  # §10 6 example value
    reply(cache, "62", "+0001000", 1.0)
    reply(cache, "CLM2", "11", 1.0)  # CWLS and ORG ON
    assert cache.axis(LOOP, "1", 1).position == 3500
    assert cache.axis(LOOP, "1", 2).position == 1000
    sensors = cache.axis(LOOP, "1", 2).sensors
    assert sensors is not None and sensors.cw_limit and sensors.org
    # '6' and 'CL' answer for the selected motor (§10 F): unknown until a selection is seen.
    reply(cache, "6", "00000007", 2.0)
    assert cache.axis(LOOP, "1", 1).position == 3500
    reply(cache, "F2", None, 2.5)
    reply(cache, "6", "00000007", 3.0)
    assert cache.axis(LOOP, "1", 2).position == 7


def test_every_change_has_the_next_number_and_its_time() -> None:
    cache = StateCache()
    seen: list[Change] = []
    cache.changes.subscribe(seen.append)
    reply(cache, "61", "00000100", 1.0)
    reply(cache, "61", "00000100", 2.0)  # nothing new: no change
    reply(cache, "61", "00000200", 3.0)
    assert [c.seq for c in seen] == list(range(1, len(seen) + 1))
    positions = [(c.time, c.values["position"]) for c in seen if "position" in c.values]
    assert positions == [(1.0, 100), (3.0, 200)]
    assert all(c.motor == 1 for c in seen if "position" in c.values)
    assert cache.seq == seen[-1].seq


def test_a_snapshot_is_as_of_the_latest_change() -> None:
    cache = StateCache()
    for i in range(20):
        reply(cache, "61", f"{i:08d}", float(i))
    latest = cache.seq
    snap = cache.snapshot()
    assert snap.seq == latest and snap.axes[LOOP, "1", 1].position == 19


def test_axes_go_stale_without_fresh_data() -> None:
    cache = StateCache(stale_after=3.0)
    reply(cache, "61", "00000000", 9.0)
    reply(cache, "62", "00000000", 9.0)
    reply(cache, "", "0", 10.0)
    assert not cache.axis(LOOP, "1", 1).stale
    cache.refresh(12.0)
    assert not cache.axis(LOOP, "1", 1).stale
    cache.refresh(13.5)
    assert cache.axis(LOOP, "1", 1).stale and cache.axis(LOOP, "1", 2).stale
    reply(cache, "61", "00000000", 14.0)  # fresh position for motor 1
    assert not cache.axis(LOOP, "1", 1).stale and cache.axis(LOOP, "1", 2).stale


def test_link_down_keeps_latches_and_marks_everything_stale() -> None:
    cache = StateCache()
    cache.set_link(LOOP, True, 0.0)
    reply(cache, "", "8", 1.0)
    cache.set_link(LOOP, False, 2.0, cause="port closed")
    assert cache.loop(LOOP).up is False and cache.loop(LOOP).cause == "port closed"
    ctl = cache.controller(LOOP, "1")
    assert ctl.online is None and ErrorKind.COMMAND in ctl.latched
    assert cache.axis(LOOP, "1", 1).stale
    cache.set_link(LOOP, True, 3.0)
    assert cache.loop(LOOP).up and cache.controller(LOOP, "1").online is None


def test_a_motion_ack_while_moving_does_not_move_the_selection() -> None:
    cache = StateCache()
    reply(cache, "31", None, 1.0)
    reply(cache, "", "1", 1.1)
    reply(cache, "42", None, 1.2)  # refused by the device: a motion command while moving
    assert cache.controller(LOOP, "1").selected_motor == 1
    assert cache.axis(LOOP, "1", 1).moving


def test_framing_is_the_schedulers_word_not_the_replies() -> None:
    # One ruler: the scheduler decides the framing (a refused EE1, a lost reply, DL...) and
    # publishes it; a reply to a framing switch or query is not a second opinion here.
    cache = StateCache()
    reply(cache, "EL1", None, 1.0)
    reply(cache, "ER", "1", 2.0)
    assert cache.controller(LOOP, "1").framing is None
    el = Framing(cr_after_ack=True)
    cache.handle(FramingChanged(loop=LOOP, time=3.0, body="1", framing=el))
    assert cache.controller(LOOP, "1").framing == el
    cache.handle(FramingChanged(loop=LOOP, time=4.0, body="1", framing=None))  # forgotten
    assert cache.controller(LOOP, "1").framing is None


def test_an_error_read_while_moving_is_latched_and_the_move_shown() -> None:
    # §10 "" (II): '>$29' = body 2 has a command error and its motor is moving.
    cache = StateCache()
    reply(cache, "", "9", 1.0, body="2")
    assert cache.controller(LOOP, "2").moving
    assert ErrorKind.COMMAND in cache.controller(LOOP, "2").latched


def test_scheduler_events_feed_the_cache() -> None:
    cache = StateCache()
    cache.handle(LinkUp(loop=LOOP, time=0.0))
    status = parse("")
    # The scheduler's own read-back after a lost move reply: '>$1A' still latches (invariant 4).
    cache.handle(
        ReplyObserved(
            loop=LOOP,
            time=1.0,
            body="1",
            command=status,
            value=decode_reply(status.reply_format, "A"),
            motor=None,
        )
    )
    assert set(cache.controller(LOOP, "1").latched) == {ErrorKind.LIMIT, ErrorKind.COMMAND}
    # '6' without a suffix: the scheduler says which motor was selected.
    six = parse("6")
    cache.handle(ReplyObserved(loop=LOOP, time=1.5, body="1", command=six, value=250, motor=2))
    assert cache.axis(LOOP, "1", 2).position == 250
    # A '>@' (ER1) motion command changed nothing: the selection stays as it was.
    cache.handle(
        ReplyObserved(loop=LOOP, time=2.0, body="1", command=parse("31"), value=None, rejected=True)
    )
    assert cache.controller(LOOP, "1").last_moved is None
    cache.handle(
        TransactionDone(
            loop=LOOP,
            time=2.5,
            body="1",
            commands=(parse("31"),),
            outcome=Outcome.NOT_DONE,
            priority=Priority.OPERATOR,
            duration=0.01,
            exchanges=1,
            counters=CountersSnapshot(transactions=7, timeouts=1),
        )
    )
    assert cache.loop(LOOP).counters["transactions"] == 7
    cache.handle(LinkDown(loop=LOOP, time=3.0, cause="port closed"))
    assert not cache.loop(LOOP).up and cache.loop(LOOP).cause == "port closed"
    assert cache.controller(LOOP, "1").online is None
    assert ErrorKind.LIMIT in cache.controller(LOOP, "1").latched


def test_an_idle_poll_publishes_nothing_yet_every_reader_sees_its_time() -> None:
    cache = StateCache()
    reply(cache, "", "0", 1.0)
    reply(cache, "61", "00003500", 1.0)
    held_ctl, held_axis = cache.controller(LOOP, "1"), cache.axis(LOOP, "1", 1)
    seq = cache.seq
    # The same answers again and again: nothing changed but the time of the latest reply.
    for t in (2.0, 3.0, 4.0):
        reply(cache, "", "0", t)
        reply(cache, "61", "00003500", t)
    assert cache.seq == seq  # no change record for a subscriber
    # A record a reader holds never changes under it ...
    assert held_ctl.updated == 1.0 and held_axis.updated == 1.0
    # ... and every way of reading shows the latest reply's time.
    assert cache.controller(LOOP, "1").updated == 4.0
    assert cache.axis(LOOP, "1", 1).updated == 4.0
    snap = cache.snapshot()
    assert snap.controllers[LOOP, "1"].updated == 4.0 and snap.axes[LOOP, "1", 2].updated == 4.0
    # Fresh for the staleness rule as well: 3 s after the last reply, not after the first.
    cache.refresh(6.5)
    assert not cache.axis(LOOP, "1", 1).stale
    cache.refresh(7.5)
    assert cache.axis(LOOP, "1", 1).stale
    # A change that comes with a reply carries that reply's time.
    change: list[Change] = []
    cache.changes.subscribe(change.append)
    reply(cache, "61", "00003600", 8.0)
    assert change and change[-1].values["position"] == 3600 and change[-1].values["updated"] == 8.0


def test_counters_are_copied_only_when_published() -> None:
    cache = StateCache()
    cache.counters_period = 1.0
    seen: list[Change] = []
    cache.changes.subscribe(seen.append)
    for i in range(25):  # 25 transactions in 2.4 s: the counters published 3 times
        done = TransactionDone(
            loop=LOOP, time=i * 0.1, body="1", commands=(parse(""),), outcome=Outcome.DONE,
            priority=Priority.POLL, duration=0.01, exchanges=1,
            counters=CountersSnapshot(transactions=i),
        )  # fmt: skip
        cache.handle(done)
    assert [c.time for c in seen if "counters" in c.values] == [0.0, 1.0, 2.0]
