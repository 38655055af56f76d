"""Motion kinematics of the simulated RC-233 against the manual's speed formulas (§7, §10).

Expected figures are worked out by hand in the comments from the manual's formulas (never by
calling the code under test):

    fH = OH × 300 / OX'    fL = OL × 300 / OX'                       (§7-1)
    α  = 1,474,560,000 / (OX' × OS)                                   (§7-1, §10 OS)
    tacc = |OH - OL| / (24,576 × (200 - OC)) × OS                     (§7-1)
    OC = 2 × ts / tacc × 100 %                                        (§7-1, §10 OC)
    speed change while moving: T = |Δ data| / 4,915,200 × OS         (§10 OH, OL, N)
    pulses of such a ramp: Pg = |v1² - v0²| / (32,768 × OX) × OS     (§10 N)

With the defaults (OH 5000, OL 500, OS 300, OX 300, OC 0): fH = 5000 pps, fL = 500 pps,
α = 1,474,560,000 / 90,000 = 16,384 pps/s, tacc = 4500 × 300 / 4,915,200 = 0.274658203125 s,
and a ramp fL <-> fH covers (500 + 5000) / 2 × tacc = 755.31005859375 pulses.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import replace

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from gateway.protocol.speeds import SpeedSettings, internal_ox, speed_constraint_violation
from gateway.sim.kinematics import (
    MotionKind,
    MotionProfile,
    SpeedLevel,
    SpeedPoint,
    plan_jog,
    plan_move,
    plan_pulse,
)
from gateway.sim.profile import ramp, ramp_distance, ramp_duration

DEFAULTS = SpeedSettings()
TACC = 4500 / (24576 * 200) * 300  # 0.274658203125 s (§7-1, defaults)
RAMP_PULSES = (500 + 5000) / 2 * TACC  # 755.31005859375 pulses fL -> fH
ALPHA = 1_474_560_000 / (300 * 300)  # 16,384 pps/s


def close(actual: float, expected: float, rel: float = 0.005) -> bool:
    """Within 0.5 %: the manual prints its figures to three digits."""
    return math.isclose(actual, expected, rel_tol=rel)


def largest_acceleration_step(profile: MotionProfile, samples: list[float]) -> float:
    """Largest change of acceleration between neighbouring samples (0 jumps: jerk-limited)."""
    accelerations = [profile.acceleration(x) for x in samples]
    return max(abs(b - a) for a, b in itertools.pairwise(accelerations))


# --- speed data -> physical values (§7-1) -------------------------------------------------


def test_defaults_give_the_manuals_figures() -> None:
    assert DEFAULTS.fh == 5000
    assert DEFAULTS.fl == 500
    assert DEFAULTS.acceleration == ALPHA == 16384
    assert DEFAULTS.tacc == pytest.approx(0.274658203125, abs=1e-15)
    assert DEFAULTS.ts == 0
    assert math.isinf(DEFAULTS.jerk)
    # OC 50: tacc = 4500 / (24,576 × 150) × 300 = 0.3662109375 s; ts = 50 / 200 × tacc.
    s_curve = SpeedSettings(oc=50)
    assert s_curve.tacc == pytest.approx(0.3662109375, abs=1e-15)
    assert s_curve.ts == pytest.approx(0.3662109375 / 4, abs=1e-15)
    # OC = 2 ts / tacc × 100 % gives back 50.
    assert 2 * s_curve.ts / s_curve.tacc * 100 == pytest.approx(50)
    # The S part reaches α from 0 in ts: jerk = α / ts.
    assert s_curve.jerk == pytest.approx(ALPHA / (0.3662109375 / 4))


def test_acceleration_takes_fl_to_fh_in_tacc() -> None:
    # α × tacc = fH - fL for OC = 0, whatever OX: this is why α uses the quantised OX'.
    for ox in (4, 28, 30, 300, 307, 15000):
        s = SpeedSettings(ox=ox)
        assert s.acceleration * s.tacc == pytest.approx(s.fh - s.fl)


@pytest.mark.parametrize(
    ("ox", "internal"),
    [
        (15000, 15000),
        (15003, 15000),
        (307, 304),
        (306, 304),
        (305, 304),
        (304, 304),
        (303, 300),
        (300, 300),
        (30, 28),  # §10 OX example: ×10.7, not ×10
        (15, 12),
        (12, 12),
        (11, 8),
        (8, 8),
        (7, 4),
        (4, 4),
        (3, 4),
        (2, 4),
    ],
)
def test_ox_is_quantised_to_multiples_of_four(ox: int, internal: int) -> None:
    assert internal_ox(ox) == internal
    assert SpeedSettings(ox=ox).ox_internal == internal


@pytest.mark.parametrize(
    ("ox", "multiplier", "low", "high"),
    [
        # §7-1 table: OX set, multiplier, output range (speed data 1 .. 16,383), as printed.
        (15000, 1 / 50, 0.02, 327),
        (304, 300 / 304, 0.987, 16167),
        (300, 1, 1, 16383),
        (12, 25, 25, 409575),
        (8, 75 / 2, 37.5, 614363),
        (2, 75, 75, 1228725),
        (7, 75, 75, 1228725),
    ],
)
def test_ox_table_of_7_1(ox: int, multiplier: float, low: float, high: float) -> None:
    s = SpeedSettings(oh=16383, ol=1, ox=ox)
    assert s.multiplier == pytest.approx(multiplier)
    assert s.fl == pytest.approx(low, abs=0.001)
    assert abs(s.fh - high) < 1  # the table rounds (327.66 -> 327, 614,362.5 -> 614,363)


def test_oh_30_gives_the_manuals_10_7() -> None:
    s = SpeedSettings(oh=100, ol=10, ox=30)
    assert s.multiplier == pytest.approx(300 / 28)
    assert s.fh == pytest.approx(1071.43, abs=0.01)
    # α = 1,474,560,000 / (28 × 300), with the quantised OX.
    assert s.acceleration == pytest.approx(1_474_560_000 / 8400)


@pytest.mark.parametrize(
    "fields",
    [
        {"oh": 0},
        {"oh": 16384},
        {"ol": 0},
        {"os": 0},
        {"os": 32768},
        {"oc": -1},
        {"oc": 101},
        {"ox": 1},
        {"ox": 16384},
    ],
)
def test_settings_outside_the_manuals_ranges_are_refused(fields: dict[str, int]) -> None:
    with pytest.raises(ValueError, match="outside"):
        SpeedSettings(**fields)


# --- S-curve constraint (§7-1, §10 OC/OH/OL) ------------------------------------------------


@pytest.mark.parametrize(
    ("oh", "ol", "oc"),
    [
        (5000, 500, 0),  # defaults: X = 0
        (5000, 500, 50),  # X = 4500 × 50 / 300 = 750
        (8191, 1, 100),  # X = 8190 × 100 / 200 = 4095, exactly the bound
        (16383, 16383, 100),  # X = 0
        (4000, 500, 50),  # §13-2 sample (OH 4000, OC 50): X = 583.3
    ],
)
def test_settings_that_keep_the_s_curve_rules(oh: int, ol: int, oc: int) -> None:
    assert speed_constraint_violation(oh, ol, oc) is None
    assert SpeedSettings(oh=oh, ol=ol, oc=oc).constraint_violation is None


@pytest.mark.parametrize(
    ("oh", "ol", "oc", "rule"),
    [
        # X = 8191 × 100 / 200 = 4095.5 > 4,095; 16,383 - 8192 = 8191 and 16,382 are kept.
        (8192, 1, 100, "exceeds 4,095"),
        # X = 8999 / 2 = 4499.5 > 4,095 only.
        (9000, 1, 100, "exceeds 4,095"),
        # X = 1000 / 2 = 500 <= 4,095 but > 16,383 - 16,000 = 383; 16,383 - 15,000 = 1383 kept.
        (16000, 15000, 100, "exceeds 16,383 - OH = 383"),
        # OH < OL: X = |15,000 - 16,000| / 2 = 500 > 16,383 - 16,000 = 383; 16,383 - OH kept.
        (15000, 16000, 100, "exceeds 16,383 - OL = 383"),
    ],
)
def test_settings_that_break_an_s_curve_rule(oh: int, ol: int, oc: int, rule: str) -> None:
    message = speed_constraint_violation(oh, ol, oc)
    assert message is not None
    assert rule in message
    assert SpeedSettings(oh=oh, ol=ol, oc=oc).constraint_violation == message


# --- ramps -------------------------------------------------------------------------------


def test_ramp_between_low_and_high_lasts_tacc() -> None:
    assert ramp_duration(500, 5000, DEFAULTS) == pytest.approx(TACC)
    assert ramp_distance(500, 5000, DEFAULTS) == pytest.approx(RAMP_PULSES)
    # §10 N: Pg = |8000² - 5000²| / (32,768 × 300) × 300 = 1190.185546875 pulses.
    assert ramp_distance(5000, 8000, DEFAULTS) == pytest.approx(1190.185546875)
    s_curve = SpeedSettings(oc=50)
    assert ramp_duration(500, 5000, s_curve) == pytest.approx(0.3662109375)
    assert ramp_duration(5000, 500, s_curve) == pytest.approx(0.3662109375)
    assert ramp(700, 700, DEFAULTS) == []
    assert ramp(700, 700, s_curve) == []


def test_s_ramp_with_oc_100_is_all_s() -> None:
    # OC 100: ts = tacc / 2, so the ramp is two S parts and no linear part.
    s = SpeedSettings(oc=100)
    pieces = ramp(s.fl, s.fh, s)
    durations = [p.duration for p in pieces if p.duration > 1e-12]
    assert len(durations) == 2
    assert durations[0] == pytest.approx(s.tacc / 2)


# --- moves (§7-1, §7-3) --------------------------------------------------------------------


def test_move_of_2000_pulses_trapezoid() -> None:
    # Two ramps 2 × 755.31 = 1510.62 pulses; cruise (2000 - 1510.62) / 5000 = 0.097876 s;
    # total 2 × 0.274658 + 0.097876 = 0.647192 s (expected: about 0.647).
    expected = 2 * TACC + (2000 - 2 * RAMP_PULSES) / 5000
    assert expected == pytest.approx(0.6471923828125)
    move = plan_move(DEFAULTS, 2000)
    assert close(move.duration, expected)
    assert move.position(move.end_time) == 2000
    assert move.speed(0) == 500
    assert move.speed(TACC + 0.01) == pytest.approx(5000)
    assert move.decel_start == pytest.approx(TACC + (2000 - 2 * RAMP_PULSES) / 5000)


def test_move_of_4000_pulses_s_curve_oc_50() -> None:
    # OC 50: tacc = 4500 / (24,576 × 150) × 300 = 0.366211 s. The S ramp is point-symmetric,
    # so it covers (500 + 5000) / 2 × 0.366211 = 1007.080 pulses; two: 2014.160.
    # Cruise (4000 - 2014.160) / 5000 = 0.397168 s; total 2 × 0.366211 + 0.397168 = 1.129590 s
    # (expected: about 1.130).
    tacc = 4500 / (24576 * 150) * 300
    expected = 2 * tacc + (4000 - 2 * 2750 * tacc) / 5000
    assert expected == pytest.approx(1.12958984375)
    move = plan_move(SpeedSettings(oc=50), 4000)
    assert close(move.duration, expected)
    assert move.position(move.end_time) == 4000
    # Middle of the up ramp: half-way in speed, at full acceleration α (linear part).
    assert move.speed(tacc / 2) == pytest.approx(2750)
    assert move.acceleration(tacc / 2) == pytest.approx(ALPHA)
    # Half-way through the first S part (ts = tacc / 4): half of α.
    assert move.acceleration(tacc / 8) == pytest.approx(ALPHA / 2)
    assert move.speed(tacc) == pytest.approx(5000)
    assert move.acceleration(tacc) == pytest.approx(0, abs=1e-6)


def test_short_move_turns_at_an_intermediate_speed_trapezoid() -> None:
    # 1000 < 1510.62 pulses: a triangle to fH' (§7-3). Each ramp covers
    # (fH'² - fL²) / (2α) = 500 pulses: fH'² = 500² + 16,384 × 1000 = 16,634,000,
    # fH' = 4078.48 pps; total 2 × (4078.48 - 500) / 16,384 = 0.436826 s (expected: about 0.437).
    peak = math.sqrt(500**2 + ALPHA * 1000)
    expected = 2 * (peak - 500) / ALPHA
    assert expected == pytest.approx(0.43683, abs=1e-5)
    move = plan_move(DEFAULTS, 1000)
    assert close(move.duration, expected)
    assert move.speed(expected / 2) == pytest.approx(peak)
    assert move.position(move.end_time) == 1000


def test_short_move_turns_at_an_intermediate_speed_s_curve() -> None:
    # OC 50: the S part gains X = 4500 × 50 / 300 = 750 pps, so the ramps keep their linear
    # part while the speed gain Δ >= 2 × 750 = 1500 pps. A ramp of gain Δ then lasts
    # Δ / α + 2 × 750 / α and covers (500 + 500 + Δ) / 2 × that. Two ramps = 1000 pulses:
    # (1000 + Δ)(Δ + 1500) / 16,384 = 1000  ->  Δ² + 2500 Δ - 14,884,000 = 0,
    # Δ = (-2500 + sqrt(65,786,000)) / 2 = 2805.43 (>= 1500, consistent); fH' = 3305.43 pps;
    # total 2 × (2805.43 + 1500) / 16,384 = 0.525565 s.
    delta = (-2500 + math.sqrt(2500**2 + 4 * 14_884_000)) / 2
    expected = 2 * (delta + 1500) / ALPHA
    assert expected == pytest.approx(0.525565, abs=1e-6)
    move = plan_move(SpeedSettings(oc=50), 1000)
    assert close(move.duration, expected)
    assert move.speed(expected / 2) == pytest.approx(500 + delta)
    assert move.position(move.end_time) == 1000


def test_very_short_s_curve_move_is_all_s() -> None:
    # 20 pulses with OC 100: no linear part at all, the peak acceleration stays below α.
    s = SpeedSettings(oc=100)
    move = plan_move(s, 20)
    assert move.position(move.end_time) == 20
    peak_accel = max(move.acceleration(move.duration * i / 400) for i in range(400))
    assert 0 < peak_accel < s.acceleration


def test_empty_move_and_single_pulse() -> None:
    nothing = plan_move(DEFAULTS, 0, start=3.0)
    assert nothing.duration == 0
    assert nothing.position(3.0) == 0
    assert not nothing.is_moving(3.0)
    assert nothing.time_at(0) == 3.0
    assert nothing.time_at(1) is None
    # 7* / 8*: one period of fL = 1 / 500 s.
    pulse = plan_pulse(DEFAULTS, start=1.0)
    assert pulse.duration == pytest.approx(0.002)
    assert pulse.position(1.001) == 0
    assert pulse.position(1.002) == 1
    assert pulse.with_settings(1.001, SpeedSettings(oh=6000)).segments == pulse.segments


def test_bad_move_arguments() -> None:
    with pytest.raises(ValueError, match="negative"):
        plan_move(DEFAULTS, -1)
    with pytest.raises(ValueError, match="OC = 0"):
        plan_move(SpeedSettings(oc=10), 100, points=(SpeedPoint(100, 50),))
    with pytest.raises(ValueError, match="speed"):
        SpeedPoint(16384, 1)
    with pytest.raises(ValueError, match="remaining"):
        SpeedPoint(1, 16_777_216)


def test_move_with_oh_below_ol_ramps_down_and_back() -> None:
    # OH 100 < OL 500: start at 500, ramp down to 100 in tacc = 400 / 4,915,200 × 300, cruise,
    # ramp back up to 500; a ramp covers (500 + 100) / 2 × tacc = 7.32 pulses.
    s = SpeedSettings(oh=100, ol=500)
    tacc = 400 / 4_915_200 * 300
    move = plan_move(s, 1000)
    expected = 2 * tacc + (1000 - 2 * 300 * tacc) / 100
    assert close(move.duration, expected)
    assert move.speed(move.duration / 2) == pytest.approx(100)
    # Shorter than both ramps: turns at a trough between 100 and 500.
    short = plan_move(s, 10)
    assert short.position(short.end_time) == 10
    assert 100 < short.speed(short.duration / 2) < 500


# --- time_at (inverse, for sensors) ---------------------------------------------------------


def test_time_at_inverts_position() -> None:
    move = plan_move(DEFAULTS, 2000, start=10.0)
    # Pulse 1000 is in the cruise: 755.31 + 5000 (t - 0.274658) = 1000 -> t = 0.323596 s.
    t = move.time_at(1000)
    assert t is not None
    assert t - 10.0 == pytest.approx(TACC + (1000 - RAMP_PULSES) / 5000, abs=1e-9)
    assert move.position(t) == 1000
    assert move.position(t - 1e-9) == 999
    assert move.time_at(0) == 10.0
    assert move.time_at(2000) == pytest.approx(move.end_time)
    assert move.time_at(2001) is None
    assert move.position(9.0) == 0
    assert move.speed(9.0) == 0
    assert move.speed(move.end_time) == 0
    assert move.acceleration(move.end_time) == 0
    jog = plan_jog(DEFAULTS)
    t = jog.time_at(12345)
    assert t is not None
    assert t == pytest.approx(12345 / 500)
    assert jog.position(t) == 12345


# --- S, SS, H, L (§10 S, SS, H, L, 7, 8) ----------------------------------------------------


def test_stop_mid_move_freezes_the_position() -> None:
    # 20,000-pulse move, S at 0.4 s (cruise): 755.31 + 5000 × (0.4 - 0.274658) = 1382.02.
    move = plan_move(DEFAULTS, 20000)
    stopped = move.stop(0.4)
    assert stopped.end == math.floor(RAMP_PULSES + 5000 * (0.4 - TACC)) == 1382
    assert stopped.end_time == pytest.approx(0.4)
    assert stopped.position(0.39) == move.position(0.39)
    assert stopped.position(0.4) == stopped.position(100.0) == 1382
    assert stopped.speed(0.41) == 0
    assert stopped.stopping
    # After the end nothing changes any more.
    assert stopped.stop(0.5) is stopped
    assert stopped.slow_stop(0.5) is stopped
    assert move.stop(move.end_time) is move
    # S before anything moved stops at 0.
    assert move.stop(-1.0).end == 0


def test_slow_stop_from_high_speed_jog() -> None:
    # Jog, H at 0: at 1 s the jog cruises at 5000 pps at 755.31 + 5000 × (1 - 0.274658)
    # = 4382.019 pulses. SS: ramp 5000 -> 500 in tacc = 0.274658 s over 755.31 pulses
    # (reaches 5137.329), then on at 500 pps to the next whole pulse 5138:
    # 0.671 / 500 = 0.001342 s; stops at 1 + 0.274658 + 0.001342 = 1.276 s.
    jog = plan_jog(DEFAULTS).to_high(0.0)
    assert jog.position(1.0) == 4382
    stopping = jog.slow_stop(1.0)
    assert stopping.end == 5138
    assert stopping.end_time == pytest.approx(1.276)
    assert stopping.speed(1.0 + TACC / 2) == pytest.approx(2750)
    assert stopping.speed(1.0 + TACC + 0.0005) == pytest.approx(500)
    assert stopping.position(stopping.end_time) == 5138
    # A second SS, H or L changes nothing; S still stops at once.
    assert stopping.slow_stop(1.1) is stopping
    assert stopping.to_low(1.1) is stopping
    assert stopping.stop(1.1).end == stopping.position(1.1)


def test_slow_stop_of_a_move() -> None:
    # 20,000-pulse move, SS at 1 s (cruise): same figures as the jog above, stops at 5138.
    move = plan_move(DEFAULTS, 20000)
    stopping = move.slow_stop(1.0)
    assert stopping.end == 5138
    assert stopping.end_time == pytest.approx(1.276)
    # SS in the final ramp: that ramp already ends at fL on the target.
    late = move.slow_stop(move.end_time - 0.1)
    assert late.end == 20000
    assert late.segments == move.segments
    assert late.stopping
    # SS of a jog at Low speed stops on the next pulse: at 1.0013 s, 500.65 -> 501.
    jog = plan_jog(DEFAULTS).slow_stop(1.0013)
    assert jog.end == 501
    assert jog.end_time == pytest.approx(501 / 500)


def test_slow_stop_during_s_curve_acceleration() -> None:
    # OC 50, SS a third into the up ramp: the acceleration first returns to 0 (no jerk
    # reversal), then the S ramp brings the speed down to fL; the stop is smooth and short.
    s = SpeedSettings(oc=50)
    move = plan_move(s, 20000)
    t = s.tacc / 3
    stopping = move.slow_stop(t)
    assert stopping.end is not None
    assert move.position(t) <= stopping.end < 20000
    samples = [t + i * 1e-4 for i in range(int((stopping.end_time - t) / 1e-4))]
    assert largest_acceleration_step(stopping, samples) <= s.jerk * 1e-4 * 1.01  # jerk-limited
    assert stopping.speed(stopping.end_time - 1e-6) == pytest.approx(500, rel=1e-3)


def test_high_and_low_during_a_jog() -> None:
    # Jog 7 at fL = 500: position 500 at 1 s. H at 1 s: ramp to 5000 in tacc (755.31 pulses).
    # At 2 s: 500 + 755.31 + 5000 × (1 - 0.274658) = 4882.02 -> 4882.
    # L at 2 s: ramp to 500 in tacc (755.31 pulses), then 500 pps. From 2 + tacc on the
    # position is 4882.019 + 755.310 + 500 (t - 2.274658) = 4500 + 500 t (the fractions
    # cancel): 6150 at 3.3 s exactly, a whole pulse reached exactly at that instant.
    jog = plan_jog(DEFAULTS)
    assert jog.kind is MotionKind.JOG
    assert jog.level is SpeedLevel.LOW
    assert jog.end_time == math.inf
    assert jog.position(1.0) == 500
    high = jog.to_high(1.0)
    assert high.level is SpeedLevel.HIGH
    assert high.speed(1.0 + TACC / 2) == pytest.approx(2750)
    assert high.speed(1.0 + TACC) == pytest.approx(5000)
    assert high.position(2.0) == 4882
    low = high.to_low(2.0)
    assert low.level is SpeedLevel.LOW
    assert low.speed(2.0 + TACC + 1e-9) == pytest.approx(500)
    assert low.position(3.3) == 6150
    assert low.position(3.3 - 1e-5) == 6149
    # H and L do not touch a move (§10 H, L: 7/8 jogs only).
    move = plan_move(DEFAULTS, 1000)
    assert move.to_high(0.1) is move
    assert move.to_low(0.1) is move


def test_high_then_low_mid_ramp_with_s_curve() -> None:
    # OC 50: H at 0, L half-way up: the acceleration returns to 0 and the S ramp goes down
    # to fL; speed and acceleration stay continuous.
    s = SpeedSettings(oc=50)
    jog = plan_jog(s).to_high(0.0)
    assert jog.speed(s.tacc) == pytest.approx(5000)
    assert jog.position(s.tacc) == math.floor(2750 * s.tacc)  # 1007.08 -> 1007
    low = jog.to_low(s.tacc / 2)
    assert low.acceleration(s.tacc / 2) == pytest.approx(s.acceleration)
    samples = [s.tacc / 2 + i * 1e-4 for i in range(12000)]
    assert largest_acceleration_step(low, samples) <= s.jerk * 1e-4 * 1.01
    assert min(low.speed(x) for x in samples) == pytest.approx(500)
    assert low.speed(samples[-1]) == pytest.approx(500)
    # H again while already ramping up carries on along the same ramp.
    again = jog.to_high(s.tacc / 3)
    for x in (s.tacc / 2, s.tacc, 2 * s.tacc):
        assert again.speed(x) == pytest.approx(jog.speed(x))
        assert again.position(x) == jog.position(x)
    # SS while L ramps down to fL carries on along that ramp, then stops on the next pulse.
    stopping = low.slow_stop(s.tacc)
    assert stopping.speed(s.tacc + 0.1) == pytest.approx(low.speed(s.tacc + 0.1))
    assert stopping.speed(stopping.end_time - 1e-6) == pytest.approx(500, rel=1e-3)
    assert stopping.end is not None
    # ...on the same curve as the jog would have followed: the jog is at that pulse then.
    assert stopping.end == low.position(stopping.end_time)
    # H again at Low speed while decelerating a little: goes back up to fH.
    up = low.to_high(s.tacc)
    assert up.speed(s.tacc + 2) == pytest.approx(5000)


# --- speed changes while moving (§10 OH, OL, OS, OX) ------------------------------------------


def test_oh_change_mid_move_trapezoid() -> None:
    # 20,000-pulse move; at 0.5 s it cruises at 5000 at 755.31 + 5000 × 0.225342 = 1882.019.
    # OH -> 8000: T1 = |8000 - 5000| / 4,915,200 × 300 = 0.183105 s over
    # (8000² - 5000²) / 32,768 = 1190.186 pulses (Pg); final T2 = |8000 - 500| / 4,915,200 ×
    # 300 = 0.457764 s over (8000² - 500²) / 32,768 = 1945.496 pulses. Cruise at 8000:
    # (20,000 - 1882.019 - 1190.186 - 1945.496) / 8000 = 1.872787 s.
    # Total 0.5 + 0.183105 + 1.872787 + 0.457764 = 3.013656 s (unchanged: 4.247192 s).
    t1 = 3000 / 4_915_200 * 300
    t2 = 7500 / 4_915_200 * 300
    at_change = RAMP_PULSES + 5000 * (0.5 - TACC)
    cruise = (20000 - at_change - (8000**2 - 5000**2) / 32768 - (8000**2 - 500**2) / 32768) / 8000
    expected = 0.5 + t1 + cruise + t2
    assert expected == pytest.approx(3.013656, abs=1e-6)
    move = plan_move(DEFAULTS, 20000)
    assert close(move.duration, 2 * TACC + (20000 - 2 * RAMP_PULSES) / 5000)
    faster = move.with_settings(0.5, SpeedSettings(oh=8000))
    assert close(faster.duration, expected)
    assert faster.position(faster.end_time) == 20000
    assert faster.position(0.5) == move.position(0.5) == 1882
    assert faster.speed(0.5 + t1 / 2) == pytest.approx(6500)
    assert faster.speed(0.5 + t1 + 0.01) == pytest.approx(8000)
    assert faster.decel_start == pytest.approx(faster.end_time - t2)
    assert faster.settings.oh == 8000
    # The same settings again change nothing.
    same = move.with_settings(0.5, DEFAULTS)
    assert same.duration == pytest.approx(move.duration)
    # In the final ramp the change comes too late for this move.
    late = move.with_settings(move.end_time - 0.1, SpeedSettings(oh=8000))
    assert late.segments == move.segments


def test_oh_change_during_the_up_ramp() -> None:
    # OH 5000 -> 3000 at 0.1 s (speed 500 + 16,384 × 0.1 = 2138.4): keeps accelerating to
    # 3000 only; the final ramp is then |3000 - 500| / 4,915,200 × 300 = 0.152588 s.
    move = plan_move(DEFAULTS, 20000).with_settings(0.1, SpeedSettings(oh=3000))
    assert move.speed(0.1 + (3000 - 2138.4) / ALPHA + 0.01) == pytest.approx(3000)
    assert move.end_time - move.decel_start == pytest.approx(2500 / 4_915_200 * 300)
    assert move.position(move.end_time) == 20000


def test_ol_change_mid_move_changes_the_stop_frequency() -> None:
    # OL 500 -> 1000 at 0.5 s (cruise at 5000, 1882.019 pulses done): the final ramp now ends
    # at 1000: |5000 - 1000| / 4,915,200 × 300 = 0.244141 s over (5000² - 1000²) / 32,768
    # = 732.422 pulses. Cruise (20,000 - 1882.019 - 732.422) / 5000 = 3.477112 s;
    # total 0.5 + 3.477112 + 0.244141 = 4.221252 s.
    expected = 0.5 + (20000 - 1882.01904296875 - 732.421875) / 5000 + 4000 / 4_915_200 * 300
    assert expected == pytest.approx(4.221252, abs=1e-6)
    move = plan_move(DEFAULTS, 20000).with_settings(0.5, SpeedSettings(ol=1000))
    assert close(move.duration, expected)
    assert move.speed(move.end_time - 1e-6) == pytest.approx(1000, rel=1e-3)
    assert move.position(move.end_time) == 20000


def test_ol_change_during_a_low_speed_jog() -> None:
    # OL 500 -> 1000 at 1 s: T = |1000 - 500| / 4,915,200 × 300 = 0.030518 s (§10 OL).
    ramp_time = 500 / 4_915_200 * 300
    jog = plan_jog(DEFAULTS).with_settings(1.0, SpeedSettings(ol=1000))
    assert jog.speed(1.0 + ramp_time / 2) == pytest.approx(750)
    assert jog.speed(1.0 + ramp_time + 1e-6) == pytest.approx(1000)
    # OH changed while at Low speed: nothing moves; H later uses the new OH.
    at_low = plan_jog(DEFAULTS).with_settings(1.0, SpeedSettings(oh=7000))
    assert at_low.speed(5.0) == pytest.approx(500)
    assert at_low.to_high(5.0).speed(10.0) == pytest.approx(7000)
    # OH changed at High speed: T1 = |7000 - 5000| / 4,915,200 × 300 = 0.12207 s.
    at_high = plan_jog(DEFAULTS).to_high(0.0).with_settings(1.0, SpeedSettings(oh=7000))
    assert at_high.speed(1.0 + 2000 / 4_915_200 * 300 + 1e-6) == pytest.approx(7000)


def test_ox_change_while_moving_jumps_without_ramp() -> None:
    # OX 300 -> 600 at 0.5 s: every speed halves at once (§10 OX: no ramp): 5000 -> 2500,
    # and the move goes on at the new fH = 2500, stopping at the new fL = 250.
    move = plan_move(DEFAULTS, 20000).with_settings(0.5, SpeedSettings(ox=600))
    assert move.speed(0.5 - 1e-9) == pytest.approx(5000)
    assert move.speed(0.5 + 1e-9) == pytest.approx(2500)
    assert move.speed(move.end_time - 1e-6) == pytest.approx(250, rel=1e-3)
    assert move.position(move.end_time) == 20000
    # OX 100 (a multiple of 4, kept as is): 500 -> 1500 pps at once.
    jog = plan_jog(DEFAULTS).with_settings(1.0, SpeedSettings(ox=100))
    assert jog.speed(1.0 + 1e-9) == pytest.approx(1500)


def test_changes_with_s_curve_keep_the_running_motion() -> None:
    # §10 OH/OL: with OC != 0 a change while moving is not guaranteed: the motion keeps its
    # course, the new values apply to the next motion (and to H/L).
    s = SpeedSettings(oc=50)
    move = plan_move(s, 20000)
    changed = move.with_settings(0.5, replace(s, oh=8000))
    assert changed.segments == move.segments
    assert changed.settings.oh == 8000
    jog = plan_jog(s).with_settings(0.5, replace(s, ol=800))
    assert jog.speed(2.0) == pytest.approx(500)
    assert jog.to_low(2.0).speed(3.0) == pytest.approx(800)
    done = plan_move(DEFAULTS, 10)
    assert done.with_settings(100.0, s).segments == done.segments


def test_settings_changed_under_a_running_s_ramp_stay_sane() -> None:
    # With OC != 0 the new values are only recorded; a later SS or L ramps with them. When the
    # motor is accelerating harder than they allow, the ramp starts from acceleration 0 at
    # once rather than overshoot (docs/manual-notes.md, "Simulator motion").
    s = SpeedSettings(oc=50)
    gentle = SpeedSettings(oh=600, ol=100, os=32767, oc=50)
    jog = plan_jog(s).to_high(0.0).with_settings(s.tacc / 2, gentle)
    stopping = jog.slow_stop(s.tacc / 2)
    assert stopping.end is not None
    assert stopping.end >= jog.position(s.tacc / 2)
    assert stopping.acceleration(s.tacc / 2) == pytest.approx(0)
    assert stopping.acceleration(s.tacc / 2 + 1) < 0
    assert min(stopping.speed(s.tacc / 2 + i * 0.5) for i in range(100)) >= 0
    check_profile(stopping, [s.tacc / 2 + i * 0.5 for i in range(100)])


# --- N speed-change points (§10 N) ---------------------------------------------------------


def test_n_points_of_the_manuals_example() -> None:
    # §10 N example: 25,000 pulses, OH 5000, points (8000 @ 20,000), (4000 @ 10,000),
    # (2500 @ 5000). α = 16,384; ramp time |Δ| / 4,915,200 × 300 = |Δ| / 16,384 s;
    # Pg = |v1² - v0²| / 32,768 pulses. A point fires when fewer than its remaining pulses are
    # left, i.e. at pulse 25,000 - pj + 1.
    #   up 500 -> 5000: 0.274658 s, 755.310 p
    #   cruise 5000 to pulse 5001: (5001 - 755.310) / 5000 = 0.849138 s
    #   5000 -> 8000: 3000 / 16,384 = 0.183105 s, 1190.186 p (to 6191.186)
    #   cruise 8000 to pulse 15,001: 8809.814 / 8000 = 1.101227 s
    #   8000 -> 4000: 0.244141 s, (64e6 - 16e6) / 32,768 = 1464.844 p (to 16,465.844)
    #   cruise 4000 to pulse 20,001: 3535.156 / 4000 = 0.883789 s
    #   4000 -> 2500: 0.091553 s, (16e6 - 6.25e6) / 32,768 = 297.546 p (to 20,298.546)
    #   final 2500 -> 500: 0.122070 s, (6.25e6 - 0.25e6) / 32,768 = 183.105 p
    #   cruise 2500 from 20,298.546 to 25,000 - 183.105 = 24,816.895: 1.807339 s
    # total 0.274658 + 0.849138 + 0.183105 + 1.101227 + 0.244141 + 0.883789 + 0.091553
    #     + 1.807339 + 0.122070 = 5.557020 s.
    up = 4500 / 16384
    c1 = (5001 - RAMP_PULSES) / 5000
    r1 = 3000 / 16384
    at_r1 = 5001 + (8000**2 - 5000**2) / 32768
    c2 = (15001 - at_r1) / 8000
    r2 = 4000 / 16384
    at_r2 = 15001 + (8000**2 - 4000**2) / 32768
    c3 = (20001 - at_r2) / 4000
    r3 = 1500 / 16384
    at_r3 = 20001 + (4000**2 - 2500**2) / 32768
    last = 2000 / 16384
    c4 = (25000 - (2500**2 - 500**2) / 32768 - at_r3) / 2500
    expected = up + c1 + r1 + c2 + r2 + c3 + r3 + c4 + last
    assert expected == pytest.approx(5.557020, abs=1e-6)
    points = (SpeedPoint(8000, 20000), SpeedPoint(4000, 10000), SpeedPoint(2500, 5000))
    move = plan_move(DEFAULTS, 25000, points=points)
    assert close(move.duration, expected)
    assert move.position(move.end_time) == 25000
    assert move.speed(up + c1 / 2) == pytest.approx(5000)
    t = up + c1 + r1 + c2 / 2
    assert move.speed(t) == pytest.approx(8000)
    t = up + c1 + r1 + c2 + r2 + c3 / 2
    assert move.speed(t) == pytest.approx(4000)
    assert move.speed(expected - last - c4 / 2) == pytest.approx(2500)
    # The point at 5000 remaining fires when 4999 are left: pulse 20,001.
    fired = move.time_at(20001)
    assert fired is not None
    assert fired == pytest.approx(up + c1 + r1 + c2 + r2 + c3, abs=1e-6)
    # A change of OH after point 1 fired does not touch the point's speed.
    changed = move.with_settings(up + c1 + r1 + 0.1, SpeedSettings(oh=3000))
    assert changed.speed(up + c1 + r1 + 0.5) == pytest.approx(8000)
    assert changed.duration == pytest.approx(move.duration)
    # ...but before point 1 fires it does.
    early = move.with_settings(0.5, SpeedSettings(oh=3000))
    assert early.speed(0.9) == pytest.approx(3000)
    assert early.speed(up + c1 + r1 + c2 / 2 + 0.5) == pytest.approx(8000)


def test_n_point_rules() -> None:
    plain = plan_move(DEFAULTS, 25000)
    # Point 1 with 0 remaining: nothing changes, point 2 is never compared.
    unset = plan_move(DEFAULTS, 25000, points=(SpeedPoint(8000, 0), SpeedPoint(1000, 10000)))
    assert unset.duration == pytest.approx(plain.duration)
    # A move shorter than point 1's remaining pulses heads for point 1's speed from the start.
    short = plan_move(DEFAULTS, 5000, points=(SpeedPoint(2000, 6000),))
    assert short.speed(0.5) == pytest.approx(2000)
    # Point 2 with more remaining than point 1 fires together with point 1 (last speed wins).
    both = plan_move(DEFAULTS, 25000, points=(SpeedPoint(8000, 20000), SpeedPoint(3000, 22000)))
    assert both.speed(3.0) == pytest.approx(3000)
    # Speed data 0 would never arrive: the slowest speed, data 1 (1 pps), is used. The point
    # fires at pulse 1001 of 2000 (before the final ramp at 2000 - 755.31): 5000 -> 1 over
    # (5000² - 1) / 32,768 = 762.94 p, then (2000 - 1001 - 762.94 - 7.63) = 228.4 p at 1 pps,
    # then the ramp back to fL = 500 ((500² - 1) / 32,768 = 7.63 p) right before the stop.
    crawl = plan_move(DEFAULTS, 2000, points=(SpeedPoint(0, 1000),))
    assert crawl.position(crawl.end_time) == 2000
    assert crawl.speed(crawl.end_time - 0.5) == pytest.approx(1)
    assert crawl.end_time - crawl.decel_start == pytest.approx(499 / 16384)
    # A point that would fire after the final ramp has begun is ignored (§10 N note 3).
    ignored = plan_move(DEFAULTS, 2000, points=(SpeedPoint(100, 3),))
    assert ignored.segments == plan_move(DEFAULTS, 2000).segments


def test_change_too_close_to_the_target_stops_on_it() -> None:
    # 20,000-pulse move; 0.01 s before its final ramp (remaining 755.31 + 50 = 805.31 pulses)
    # OS 300 -> 600 halves α to 1,474,560,000 / (300 × 600) = 8192 pps/s: the ramp 5000 -> 500
    # now needs (5000² - 500²) / (2 × 8192) = 1510.6 pulses > 805.31. The motor ramps down at
    # once and stops on the target (never overshoots), at v² = 5000² - 2 × 8192 × 805.31:
    # v = 3436.6 pps.
    move = plan_move(DEFAULTS, 20000)
    t = move.decel_start - 0.01
    late = move.with_settings(t, SpeedSettings(os=600))
    assert late.decel_start == pytest.approx(t)
    assert late.position(late.end_time) == 20000
    end_speed = math.sqrt(5000**2 - 2 * 8192 * (RAMP_PULSES + 50))
    assert late.speed(late.end_time - 1e-9) == pytest.approx(end_speed, rel=1e-4)


# --- properties over many settings and moves (hypothesis) --------------------------------


@st.composite
def speed_settings(draw: st.DrawFn, *, trapezoid: bool = False) -> SpeedSettings:
    s = SpeedSettings(
        oh=draw(st.integers(1, 16383)),
        ol=draw(st.integers(1, 16383)),
        os=draw(st.integers(1, 32767)),
        oc=0 if trapezoid else draw(st.sampled_from([0, 0, 1, 25, 50, 99, 100])),
        ox=draw(st.sampled_from([2, 8, 28, 150, 300, 304, 1000, 16383])),
    )
    assume(s.constraint_violation is None)
    return s


def check_profile(profile: MotionProfile, times: list[float]) -> None:
    """Positions monotonic, speeds >= 0, exact end, time_at consistent."""
    positions = [profile.position(t) for t in sorted(times)]
    assert positions == sorted(positions)
    assert all(p >= 0 for p in positions)
    assert all(profile.speed(t) >= -1e-9 for t in times)
    if profile.end is not None:
        assert profile.position(profile.end_time) == profile.end
        assert all(p <= profile.end for p in positions)
    for k in {positions[0], positions[-1], (positions[0] + positions[-1]) // 2}:
        t = profile.time_at(k)
        assert t is not None
        assert profile.position(t) >= k
        if k > 0:  # the earliest such time: one float earlier, pulse k is not out yet
            assert profile.position(math.nextafter(t, -math.inf)) < k


@settings(max_examples=300, deadline=None)
@given(
    s=speed_settings(),
    distance=st.integers(1, 16_777_215),
    fractions=st.lists(st.floats(0, 1), min_size=2, max_size=30),
    at=st.floats(0, 1),
)
def test_any_move_ends_exactly_on_its_target(
    s: SpeedSettings, distance: int, fractions: list[float], at: float
) -> None:
    move = plan_move(s, distance)
    assert move.position(move.end_time) == distance
    assert move.position(move.end_time * (1 - 1e-9)) <= distance
    top = max(s.fh, s.fl) * (1 + 1e-9)
    assert all(move.speed(f * move.end_time) <= top for f in fractions)
    check_profile(move, [f * move.end_time for f in fractions])
    k = max(1, distance // 3)
    t = move.time_at(k)
    assert t is not None
    assert move.position(t) >= k
    assert move.position(math.nextafter(t, -math.inf)) < k
    for stopped in (move.stop(at * move.end_time), move.slow_stop(at * move.end_time)):
        assert stopped.end is not None
        assert move.position(at * move.end_time) <= stopped.end <= distance
        check_profile(stopped, [f * stopped.end_time for f in fractions])


@settings(max_examples=200, deadline=None)
@given(
    s=speed_settings(trapezoid=True),
    new=speed_settings(trapezoid=True),
    distance=st.integers(1, 1_000_000),
    points=st.lists(
        st.builds(SpeedPoint, st.integers(0, 16383), st.integers(0, 1_000_000)), max_size=5
    ),
    at=st.floats(0, 1),
    fractions=st.lists(st.floats(0, 1), min_size=2, max_size=20),
)
def test_any_trapezoid_move_with_changes_ends_exactly(
    s: SpeedSettings,
    new: SpeedSettings,
    distance: int,
    points: list[SpeedPoint],
    at: float,
    fractions: list[float],
) -> None:
    move = plan_move(s, distance, points=tuple(points))
    assert move.position(move.end_time) == distance
    changed = move.with_settings(at * move.end_time, new)
    assert changed.position(changed.end_time) == distance
    check_profile(changed, [f * changed.end_time for f in fractions])
    slow = move.slow_stop(at * move.end_time)
    assert slow.end is not None
    assert move.position(at * move.end_time) <= slow.end <= distance
    check_profile(slow, [f * slow.end_time for f in fractions])


@settings(max_examples=200, deadline=None)
@given(
    s=speed_settings(),
    new=speed_settings(),
    steps=st.lists(
        st.tuples(st.sampled_from(["H", "L", "SET", "SS", "S"]), st.floats(0, 3)), max_size=8
    ),
)
def test_any_jog_command_sequence_stays_consistent(
    s: SpeedSettings, new: SpeedSettings, steps: list[tuple[str, float]]
) -> None:
    jog = plan_jog(s)
    t = 0.0
    times = [0.0]
    for command, gap in steps:
        t += gap * max(s.tacc, 1 / s.fl)
        times.append(t)
        before = jog.position(t)
        if command == "H":
            jog = jog.to_high(t)
        elif command == "L":
            jog = jog.to_low(t)
        elif command == "SET":
            jog = jog.with_settings(t, replace(new, oc=s.oc) if new.oc != s.oc else new)
        elif command == "SS":
            jog = jog.slow_stop(t)
        else:
            jog = jog.stop(t)
        assert jog.position(t) >= before
    times.append(t + 10 * max(s.tacc, 1 / s.fl))
    check_profile(jog, times)
