"""One simulated axis: moves, jogs, stops, limits, EMS, sensors, faults (§4-4, §7, §10).

Expected figures are the manual's formulas worked by hand (as in test_kinematics):
defaults OH 5000, OL 500, OS 300, OX 300, OC 0 give fH 5000 pps, fL 500 pps,
α = 1,474,560,000 / (300 × 300) = 16,384 pps/s, tacc = 4500 / 4,915,200 × 300 = 0.274658203125 s,
and a ramp fL <-> fH covers (500 + 5000) / 2 × tacc = 755.31005859375 pulses.
"""

from __future__ import annotations

import pytest

from gateway.protocol.reply_values import Contact, SensorLogic, SpeedPoint
from gateway.protocol.speeds import SpeedSettings
from gateway.sim.axis import (
    Axis,
    AxisBusy,
    AxisEvent,
    AxisEventKind,
    Direction,
    SensorName,
)
from gateway.sim.scene import AxisScene

DEFAULTS = SpeedSettings()
TACC = 4500 / (24576 * 200) * 300  # 0.274658203125 s
RAMP_PULSES = (500 + 5000) / 2 * TACC  # 755.31005859375
START = 30_000
LIMIT = AxisEventKind.LIMIT


def axis(**scene: object) -> Axis:
    return Axis(AxisScene(**scene))  # type: ignore[arg-type]


def kinds(events: list[AxisEvent]) -> list[AxisEventKind]:
    return [event.kind for event in events]


# --- moves and their durations (§7-1, §10 3/4/5) ------------------------------------------


def test_move_of_2000_pulses_ends_on_target_at_the_manuals_time() -> None:
    # Two ramps of tacc and a cruise of (2000 - 2 × 755.31) / 5000 s: 0.647192 s.
    end = 2 * TACC + (2000 - 2 * RAMP_PULSES) / 5000
    assert end == pytest.approx(0.6472, abs=1e-4)
    a = axis()
    a.move(0.0, 2000, DEFAULTS)
    assert a.is_moving(end - 1e-4)
    assert a.counter(end - 1e-4) < 2000
    assert not a.is_moving(end + 1e-6)
    assert a.counter(end + 1e-6) == 2000
    assert a.mechanical(5.0) == START + 2000
    assert a.advance(5.0) == []


def test_negative_distance_is_ccw_and_zero_does_nothing() -> None:
    a = axis()
    a.move(0.0, 0, DEFAULTS)
    assert not a.is_moving(0.0)
    a.move(0.0, -1500, DEFAULTS)
    assert a.speed(0.1) < 0  # CCW: the counter counts down
    assert a.counter(5.0) == -1500
    assert a.mechanical(5.0) == START - 1500


def test_speed_is_signed_and_zero_at_rest() -> None:
    a = axis()
    assert a.speed(0.0) == 0
    a.jog(0.0, Direction.CW, DEFAULTS)
    assert a.speed(0.5) == 500  # fL, no ramp (§10 7)
    a.stop(1.0)
    a.jog(1.0, Direction.CCW, DEFAULTS)
    assert a.speed(1.5) == -500


def test_n_points_change_the_speed_of_a_move() -> None:
    # §10 N: fewer than 3,000 pulses left -> speed data 1000; ramp 4000 / 4,915,200 × 300 s.
    a = axis()
    a.move(0.0, 10_000, DEFAULTS, (SpeedPoint(1000, 3000),))
    # 7,001 pulses are done at tacc + (7001 - 755.31) / 5000 s; the ramp ends 0.2441 s later.
    fired = TACC + (7001 - RAMP_PULSES) / 5000
    assert a.speed(fired - 0.01) == 5000
    assert a.speed(fired + 4000 / 4_915_200 * 300 + 0.01) == pytest.approx(1000)
    assert a.counter(10.0) == 10_000


def test_seven_star_and_eight_star_are_one_pulse() -> None:
    a = axis()
    a.step(0.0, Direction.CW, DEFAULTS)
    assert a.is_moving(0.001)  # one period of fL = 2 ms
    assert a.counter(0.002) == 1
    a.step(0.01, Direction.CCW, DEFAULTS)
    assert a.counter(0.02) == 0


def test_start_counter_is_where_the_motion_began() -> None:
    # §10 2 注意点: form II while moving stores "the position before the motor started".
    a = axis()
    a.preset(0.0, 1000)
    a.jog(0.0, Direction.CW, DEFAULTS)
    assert a.counter(1.0) == 1500
    assert a.start_counter == 1000


def test_preset_sets_the_counter_only() -> None:
    # §10 R: "R8000" - the current position becomes 8,000; the origin lies 8,000 pulses CCW.
    a = axis()
    a.preset(0.0, 8000)
    assert a.counter(0.0) == 8000
    assert a.mechanical(0.0) == START
    a.move(0.0, -8000, DEFAULTS)
    assert a.counter(10.0) == 0
    assert a.mechanical(10.0) == START - 8000


def test_a_second_motion_while_moving_is_refused() -> None:
    a = axis()
    a.jog(0.0, Direction.CW, DEFAULTS)
    with pytest.raises(AxisBusy):
        a.move(1.0, 100, DEFAULTS)


def test_time_cannot_go_back() -> None:
    a = axis()
    a.advance(2.0)
    with pytest.raises(ValueError, match="back"):
        a.counter(1.0)


# --- limits (§4-4, §10 7/8 注意点) --------------------------------------------------------


def test_move_into_the_cw_limit_stops_there_with_limit() -> None:
    a = axis(cw_limit=START + 1000)
    a.move(0.0, 5000, DEFAULTS)
    # Pulse 1,000 is out after the ramp (755.31 pulses) and (1000 - 755.31) / 5000 s of cruise.
    hit = TACC + (1000 - RAMP_PULSES) / 5000
    assert a.is_moving(hit - 1e-4)
    assert not a.is_moving(hit + 1e-6)
    events = a.advance(1.0)
    assert kinds(events) == [LIMIT]
    assert events[0].time == pytest.approx(hit, abs=1e-6)
    assert a.counter(1.0) == 1000
    assert a.mechanical(1.0) == START + 1000
    assert a.sensors(1.0).cw_limit


def test_jog_into_the_ccw_limit() -> None:
    a = axis(ccw_limit=START - 300, org_start=START + 100, org_end=START + 200)
    a.jog(0.0, Direction.CCW, DEFAULTS)
    events = a.advance(2.0)
    assert events == [AxisEvent(pytest.approx(300 / 500), LIMIT)]  # type: ignore[arg-type]
    assert a.counter(2.0) == -300


def test_motion_towards_a_limit_that_is_on_does_not_start() -> None:
    # §4-4 "ON するとパルス出力が停止"; §8-2 ① (2): '>$12' - a limit is ON, the motor stopped.
    a = axis(cw_limit=START)
    a.move(0.0, 100, DEFAULTS)
    assert kinds(a.advance(0.0)) == [LIMIT]
    assert a.counter(1.0) == 0
    a.step(1.0, Direction.CW, DEFAULTS)
    assert kinds(a.advance(1.0)) == [LIMIT]
    a.move(1.0, -100, DEFAULTS)  # away from it: fine
    assert a.counter(3.0) == -100
    assert a.advance(3.0) == []


def test_b_logic_on_unconnected_limits_reads_on_and_blocks_motion() -> None:
    # §10 EA 注意点: B logic on an input with no sensor reads ON all the time;
    # §4-4: with a wrong limit logic the motor does not move at all.
    a = axis(connected=frozenset({SensorName.ORG, SensorName.EZ}))
    a.logic = SensorLogic(limit=Contact.B)
    bits = a.sensors(0.0)
    assert bits.cw_limit
    assert bits.ccw_limit
    a.move(0.0, 1000, DEFAULTS)
    a.jog(0.0, Direction.CCW, DEFAULTS)
    assert kinds(a.advance(1.0)) == [LIMIT, LIMIT]
    assert a.counter(1.0) == 0


def test_normally_closed_limits_with_b_logic_work() -> None:
    closed = frozenset({SensorName.CW_LIMIT, SensorName.CCW_LIMIT})
    a = axis(normally_closed=closed, cw_limit=START + 200)
    a.logic = SensorLogic(limit=Contact.B)
    bits = a.sensors(0.0)
    assert (bits.cw_limit, bits.ccw_limit) == (False, False)
    a.jog(0.0, Direction.CW, DEFAULTS)
    assert kinds(a.advance(1.0)) == [LIMIT]
    assert a.mechanical(1.0) == START + 200


# --- S, SS, H, L, speed changes (§10 S, SS, H, L, OH) --------------------------------------


def test_s_stops_at_once() -> None:
    a = axis()
    a.jog(0.0, Direction.CW, DEFAULTS)
    a.stop(1.0)
    assert not a.is_moving(1.0)
    assert a.counter(1.0) == 500  # 1 s at fL
    assert a.counter(5.0) == 500
    assert a.advance(5.0) == []


def test_h_and_l_during_a_jog() -> None:
    a = axis()
    a.jog(0.0, Direction.CCW, DEFAULTS)
    a.to_high(1.0)
    # α = 16,384 pps/s: 0.1 s into the ramp the speed is 500 + 1638.4.
    assert a.speed(1.1) == pytest.approx(-(500 + 1638.4))
    assert a.speed(1.0 + TACC + 0.01) == pytest.approx(-5000)
    a.to_low(2.0)
    assert a.speed(2.0 + TACC + 0.01) == pytest.approx(-500)
    assert a.is_moving(3.0)


def test_ss_decelerates_to_low_speed_then_stops() -> None:
    a = axis()
    a.jog(0.0, Direction.CW, DEFAULTS)
    a.to_high(0.0)
    at_ss = a.counter(1.0)  # cruising at fH since tacc
    a.slow_stop(1.0)
    assert a.speed(1.0 + TACC / 2) == pytest.approx(2750, rel=1e-3)  # half-way down
    assert not a.is_moving(1.0 + TACC + 0.0021)  # fL reached, at most one more 2 ms pulse
    # The ramp 5000 -> 500 covers 755.31 pulses; it stops on the next whole pulse.
    assert a.counter(3.0) - at_ss in (755, 756, 757)
    assert a.advance(3.0) == []


def test_ss_of_a_low_speed_jog_stops_on_the_next_pulse() -> None:
    a = axis()
    a.jog(0.0, Direction.CW, DEFAULTS)
    a.slow_stop(1.001)  # between pulse 500 (1.000 s) and pulse 501 (1.002 s)
    assert a.counter(2.0) == 501


def test_oh_changed_while_jogging_at_high_speed() -> None:
    # §10 OH: T1 = |OH' - OH| / 4,915,200 × OS = 2500 / 4,915,200 × 300 = 0.152588 s.
    a = axis()
    a.jog(0.0, Direction.CW, DEFAULTS)
    a.to_high(0.0)
    a.retune(1.0, SpeedSettings(oh=2500))
    assert a.speed(1.0 + 0.152588 - 0.01) > 2500
    assert a.speed(1.0 + 0.152588 + 0.01) == pytest.approx(2500)


def test_limit_still_watched_after_a_speed_change() -> None:
    a = axis(cw_limit=START + 3000)
    a.jog(0.0, Direction.CW, DEFAULTS)
    a.to_high(0.5)
    events = a.advance(10.0)
    assert kinds(events) == [LIMIT]
    assert a.mechanical(10.0) == START + 3000


# --- EMS and fault injection --------------------------------------------------------------


def test_emergency_stops_at_once() -> None:
    a = axis()
    a.move(0.0, 50_000, DEFAULTS)
    at = a.counter(2.0)
    a.emergency(2.0)
    assert not a.is_moving(2.0)
    assert a.counter(9.0) == at
    assert a.advance(9.0) == [AxisEvent(2.0, AxisEventKind.EMERGENCY)]


def test_forced_limit_stops_a_move_when_forced() -> None:
    a = axis()
    a.jog(0.0, Direction.CW, DEFAULTS)
    a.advance(1.0)
    a.force(SensorName.CW_LIMIT, True)  # at the last advance time, 1.0 s
    assert a.advance(1.0) == [AxisEvent(1.0, LIMIT)]
    assert a.counter(1.0) == 500
    assert a.sensors(1.0).cw_limit
    a.force(SensorName.CW_LIMIT, None, now=2.0)
    assert not a.sensors(2.0).cw_limit


def test_forcing_the_other_limit_does_not_stop() -> None:
    a = axis()
    a.jog(0.0, Direction.CW, DEFAULTS)
    a.force(SensorName.CCW_LIMIT, True, now=1.0)
    assert a.is_moving(2.0)
    assert a.advance(2.0) == []


def test_forced_sensor_by_plain_name() -> None:
    a = axis()
    a.force("org", True)  # type: ignore[arg-type]
    assert a.sensors(0.0).org


def test_slip_moves_the_mechanics_but_not_the_counter() -> None:
    a = axis(cw_limit=START + 1000)
    a.jog(0.0, Direction.CW, DEFAULTS)
    a.slip(0.5, -30)  # 30 pulses lost at 0.5 s (250 pulses done)
    assert a.counter(0.5) == 250
    assert a.mechanical(0.5) == START + 220
    a.advance(10.0)
    # The limit is where the mechanics reach it: the counter shows 30 more pulses.
    assert a.mechanical(10.0) == START + 1000
    assert a.counter(10.0) == 1030


def test_events_come_once_and_in_time_order() -> None:
    a = axis(cw_limit=START + 100, ccw_limit=START - 100, org_start=START - 50, org_end=START)
    a.jog(0.0, Direction.CW, DEFAULTS)
    a.counter(1.0)  # a query runs the limit stop but keeps its event for advance()
    a.jog(1.0, Direction.CCW, DEFAULTS)
    events = a.advance(5.0)
    assert kinds(events) == [LIMIT, LIMIT]
    assert events[0].time < events[1].time
    assert a.advance(5.0) == []
