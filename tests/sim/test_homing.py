"""Origin searches 0, 0A, 0H, 0R, 0Z, 0Q from each starting case (§10 0 ... 0X, §3-V).

Scene (AxisScene defaults): CCW limit at -5,000, ORG actuated from 0 to 499, CW limit at
95,000. Speeds are the defaults: Low fL = 500 pps (2 ms a pulse), High fH = 5,000 pps; a ramp
between them covers (500 + 5000) / 2 × 0.274658 s = 755.31 pulses (§7-1).

Worked by hand from the manual's text, for the final CCW approach of 0 / 0A / 0H:
ORG turns ON at its CW edge, 499 (§10 0 A); it is recognised 20 ms later, 10 pulses at
500 pps, and pulse output stops at 489 (§10 0X ①②); 5 pulses CCW to 484, where ORG is ON
(③); then 0S = 20 pulses to 464, the origin (④). ``legs`` lists where each stretch of motion
ended, so the expected lists below are the path the manual's text describes.
"""

from __future__ import annotations

from typing import Any

import pytest

from gateway.protocol.speeds import SpeedSettings
from gateway.sim.axis import (
    Axis,
    AxisEvent,
    AxisEventKind,
    HomingMethod,
    HomingSetup,
    SensorName,
)
from gateway.sim.scene import AxisScene, EzWiring

DEFAULTS = SpeedSettings()
SETUP = HomingSetup()
HOMED = AxisEventKind.HOMED
LIMIT = AxisEventKind.LIMIT
CLEAR = AxisEventKind.CLEAR
ORIGIN = HomingMethod.ORIGIN
HIGH_A = HomingMethod.HIGH_IMMEDIATE
HIGH_H = HomingMethod.HIGH_DECELERATE
REVERSE = HomingMethod.REVERSE
Z_PHASE = HomingMethod.Z_PHASE
STEP_OUT = HomingMethod.STEP_OUT

CW_OF_ORG, ON_ORG, CCW_OF_ORG = 3000, 200, -3000
#: The final CCW approach with the defaults (module docstring).
APPROACH = [489, 484, 464]
#: CW off ORG (first OFF at 500), 0S × 0B = 40 pulses further, then the approach.
BACK_OFF = [500, 540, *APPROACH]


def search(
    method: HomingMethod,
    start: int,
    setup: HomingSetup = SETUP,
    settings: SpeedSettings = DEFAULTS,
    **scene: object,
) -> tuple[Axis, list[AxisEvent]]:
    """Run a whole search from ``start``; the axis and every event."""
    axis = Axis(AxisScene(start=start, **scene))  # type: ignore[arg-type]
    axis.home(0.0, method, setup, settings)
    return axis, axis.advance(10_000.0)


def path(axis: Axis) -> list[int]:
    return [leg.end_position for leg in axis.legs]


def assert_homed_at(axis: Axis, events: list[AxisEvent], origin: int) -> None:
    assert [event.kind for event in events] == [HOMED]
    assert axis.mechanical(10_000.0) == origin
    assert axis.counter(10_000.0) == 0
    assert not axis.is_moving(10_000.0)
    assert not axis.homing


# --- 0: origin search 1 (§10 0) ------------------------------------------------------------


def test_origin_from_cw_of_org() -> None:
    # §10 0 A: Low speed CCW; ORG ON; 0S more pulses; stop; that point is 0.
    axis, events = search(ORIGIN, CW_OF_ORG)
    assert path(axis) == APPROACH
    assert_homed_at(axis, events, 464)
    # (3000 - 489) + 5 + 20 pulses at 2 ms each.
    assert events[0].time == pytest.approx((3000 - 464) / 500)


def test_origin_from_on_org() -> None:
    # §10 0 B: CW until ORG OFF, 0S × 0B further, reverse CCW, ORG ON, 0S, stop.
    axis, events = search(ORIGIN, ON_ORG)
    assert path(axis) == BACK_OFF
    assert_homed_at(axis, events, 464)


def test_origin_from_ccw_of_org_reverses_at_the_ccw_limit() -> None:
    # §10 0 C: CCW until CCW LS ON, reverse CW, ORG ON then OFF, 0S × 0B, reverse, ORG, 0S.
    axis, events = search(ORIGIN, CCW_OF_ORG)
    assert path(axis) == [-5000, *BACK_OFF]
    assert_homed_at(axis, events, 464)  # the reversal is no limit error


def test_search_pulses_and_back_factor_show_in_the_path() -> None:
    # 0S 50, 0B 3: back off 150 past ORG; the origin is 50 pulses past 484.
    axis, events = search(ORIGIN, ON_ORG, HomingSetup(search_pulses=50, back_factor=3))
    assert path(axis) == [500, 650, 489, 484, 434]
    assert_homed_at(axis, events, 434)
    # 0B 0: no back-off at all; the approach starts right at ORG's OFF edge.
    axis, events = search(ORIGIN, ON_ORG, HomingSetup(back_factor=0))
    assert path(axis) == [500, *APPROACH]
    assert_homed_at(axis, events, 464)


def test_recognition_delay_moves_the_stop_by_speed_times_20_ms() -> None:
    # §10 0X ①: OL 1000 (fL 1000 pps): 20 ms are 20 pulses instead of 10.
    axis, events = search(ORIGIN, CW_OF_ORG, settings=SpeedSettings(ol=1000))
    assert path(axis) == [479, 474, 454]
    assert_homed_at(axis, events, 454)


def test_org_must_stay_on_for_six_pulses() -> None:
    # §3-V: ORG ON for fewer than 6 pulses is not recognised.
    small: dict[str, Any] = {"ccw_limit": -100, "cw_limit": 3000, "org_start": 0}
    axis, events = search(ORIGIN, 1000, org_end=5, **small)  # 6 pulses: recognised
    # Stopped 20 ms (10 pulses) after its CW edge, past it: the 5-pulse steps of §10 0X ③
    # never find it ON again and end at the CCW limit, an error stop.
    assert path(axis) == [-5, *range(-10, -100, -5), -100]
    assert [event.kind for event in events] == [LIMIT]
    axis, events = search(ORIGIN, 1000, org_end=4, **small)  # 5 pulses: passed over
    assert path(axis) == [-100, 3000]  # to the CCW limit, back, on to the CW limit
    assert [event.kind for event in events] == [LIMIT]


def test_origin_without_org_runs_into_the_cw_limit() -> None:
    # §10 0 注意点: with no ORG sensor the motor runs until the CW limit turns ON.
    wired = frozenset({SensorName.CW_LIMIT, SensorName.CCW_LIMIT, SensorName.EZ})
    axis, events = search(ORIGIN, CW_OF_ORG, connected=wired)
    assert path(axis) == [-5000, 95_000]
    assert [event.kind for event in events] == [LIMIT]
    assert axis.counter(10_000.0) == 95_000 - CW_OF_ORG  # not homed: no new origin


def test_r_preset_is_ignored_by_the_search() -> None:
    # §10 R 注意点: homing looks for the ORG sensor whatever R set.
    axis = Axis(AxisScene(start=CW_OF_ORG))
    axis.preset(0.0, 8000)
    axis.home(0.0, ORIGIN, SETUP, DEFAULTS)
    assert_homed_at(axis, axis.advance(10_000.0), 464)


# --- 0A and 0H: High speed searches (§10 0A, 0H) ------------------------------------------


@pytest.mark.parametrize("start", [CW_OF_ORG, 30_000])
def test_0a_stops_at_once_when_org_is_recognised(start: int) -> None:
    # §10 0A A: High speed CCW; ORG ON: stop at once (20 ms = 100 pulses at 5000 pps past its
    # edge: 399); Low speed CW: ORG ON then OFF; 0S × 0B; reverse; the usual approach.
    # The 100th pulse falls due at the very moment of recognition: it is output.
    axis, events = search(HIGH_A, start)
    assert path(axis) == [399, *BACK_OFF]
    assert_homed_at(axis, events, 464)


def test_0h_decelerates_to_low_speed_before_reversing() -> None:
    # §10 0H A: from the recognition (399) the ramp 5000 -> 500 pps covers 755.31 pulses.
    axis, events = search(HIGH_H, CW_OF_ORG)
    reversal, *rest = path(axis)
    assert abs(reversal - (399 - 755.31)) <= 1
    assert rest == BACK_OFF
    assert_homed_at(axis, events, 464)


def test_0h_ccw_limit_during_the_deceleration() -> None:
    # §10 0H: "減速期間中に CCW LS が ON すると、その瞬間から低速で CW 方向に".
    axis, events = search(HIGH_H, CW_OF_ORG, ccw_limit=-200)
    assert path(axis) == [-200, *BACK_OFF]
    assert_homed_at(axis, events, 464)


@pytest.mark.parametrize("method", [HIGH_A, HIGH_H])
def test_high_speed_search_from_on_org_is_like_0_b(method: HomingMethod) -> None:
    axis, events = search(method, ON_ORG)
    assert path(axis) == BACK_OFF
    assert_homed_at(axis, events, 464)


@pytest.mark.parametrize("method", [HIGH_A, HIGH_H])
def test_high_speed_search_from_ccw_of_org(method: HomingMethod) -> None:
    # §10 0A/0H B: High speed CCW to the CCW LS, then Low speed CW: ORG ON, OFF, ...
    axis, events = search(method, CCW_OF_ORG)
    assert path(axis) == [-5000, *BACK_OFF]
    assert_homed_at(axis, events, 464)
    first = axis.legs[0]
    assert first.end - first.start < (3000 - 755) / 5000 + 0.3  # it went at High speed


# --- 0R: origin search 2 (§10 0R) ----------------------------------------------------------

#: Final approach CW: ORG ON at its CCW edge (0), recognised at 10, 5 more to 15, 0S to 35.
APPROACH_CW = [10, 15, 35]


@pytest.mark.parametrize("start", [CW_OF_ORG, ON_ORG])
def test_0r_from_cw_of_or_on_org(start: int) -> None:
    # §10 0R A: CCW, ORG ON, on until OFF (-1), reverse, ORG ON again, 0S, stop.
    axis, events = search(REVERSE, start)
    assert path(axis) == [-1, *APPROACH_CW]
    assert_homed_at(axis, events, 35)


def test_0r_from_between_org_and_the_ccw_limit() -> None:
    # §10 0R B: CCW until CCW LS, reverse, ORG ON, 0S, stop.
    axis, events = search(REVERSE, CCW_OF_ORG)
    assert path(axis) == [-5000, *APPROACH_CW]
    assert_homed_at(axis, events, 35)


def test_0r_cw_limit_is_an_error_stop() -> None:
    # §10 0R 注意点: CW LS ON during the search is an error stop.
    wired = frozenset({SensorName.CW_LIMIT, SensorName.CCW_LIMIT})
    axis, events = search(REVERSE, CW_OF_ORG, connected=wired)
    assert path(axis) == [-5000, 95_000]
    assert [event.kind for event in events] == [LIMIT]


# --- 0Z: ORG and the encoder Z phase (§10 0Z) -----------------------------------------------

#: Z phase ON for 10 pulses of every 1,000: 0-9, -1000 to -991, ...; going CCW each pulse is
#: entered at its CW end. After the n-th: reverse CW until Z goes OFF (one past the CW end),
#: then 5 pulses CCW: the origin lies 4 pulses inside the n-th Z pulse.
Z_SCENE: dict[str, Any] = {"ez": EzWiring.Z, "z_period": 1000, "z_width": 10, "z_offset": 0}


def test_0z_from_cw_of_org() -> None:
    axis, events = search(Z_PHASE, CW_OF_ORG, **Z_SCENE)
    reversal, *rest = path(axis)
    assert 0 <= reversal <= 9  # inside the first Z pulse after ORG
    assert rest == [10, 5]
    assert_homed_at(axis, events, 5)


def test_0z_counts_the_nth_z_pulse() -> None:
    # 0Z3: the third Z pulse after ORG, -2000 to -1991; origin -1995.
    axis, events = search(Z_PHASE, CW_OF_ORG, HomingSetup(z_count=3), **Z_SCENE)
    assert path(axis)[-2:] == [-1990, -1995]
    assert_homed_at(axis, events, -1995)


def test_0z_ignores_z_before_org_is_confirmed() -> None:
    # §10 0Z figure D: a Z pulse (495-504) over ORG's edge (499) ends before ORG has been ON
    # long enough (6 pulses, to 494): it does not count; the next one (-505 to -496) does.
    scene: dict[str, Any] = {**Z_SCENE, "z_offset": 495}
    axis, events = search(Z_PHASE, CW_OF_ORG, **scene)
    assert_homed_at(axis, events, -500)


def test_0z_from_on_org_and_from_ccw_of_org() -> None:
    # §10 0Z C: CW until ORG OFF, 0S × 0B, reverse CCW, ORG, Z. B: first CCW to the limit.
    for start, before in ((ON_ORG, [500, 540]), (CCW_OF_ORG, [-5000, 500, 540])):
        axis, events = search(Z_PHASE, start, **Z_SCENE)
        steps = path(axis)
        assert steps[: len(before)] == before
        assert steps[-2:] == [10, 5]
        assert_homed_at(axis, events, 5)


def test_0z_limit_after_org_is_an_error() -> None:
    # ORG found, then the CCW limit before the third Z pulse: error stop (our choice).
    axis, events = search(Z_PHASE, CW_OF_ORG, HomingSetup(z_count=3), ccw_limit=-1500, **Z_SCENE)
    assert path(axis) == [-1500]
    assert [event.kind for event in events] == [LIMIT]


# --- 0Q: step-out sensor centring (§10 0Q) ---------------------------------------------------

#: The default dog: ON where position mod 400 < 200; from 3250 the ON stretch is 3200-3399.
DOG_START = 3250


def test_0q_centres_the_sensor_on_the_dog() -> None:
    # To the dog's CCW edge (OFF at 3199), CW across it (ON 3200, OFF 3400: 200 pulses),
    # back half of it: 3300 is the middle and the origin.
    axis, events = search(STEP_OUT, DOG_START)
    assert path(axis) == [3199, 3400, 3300]
    assert axis.step_out_width == 200  # 0QW
    assert_homed_at(axis, events, 3300)


def test_0q_guard_longer_than_the_dog_gives_a_wrong_centre() -> None:
    # §10 0Q 注意点: pd above the real ON width gives an inaccurate centre.
    axis, events = search(STEP_OUT, DOG_START, HomingSetup(step_out_pulses=300))
    assert axis.step_out_width == 300
    assert_homed_at(axis, events, 3350)


def test_0q_needs_the_sensor_on() -> None:
    axis = Axis(AxisScene(start=3000))  # 3000 mod 400 = 200: OFF
    with pytest.raises(ValueError, match="0Q"):
        axis.home(0.0, STEP_OUT, SETUP, DEFAULTS)
    assert not axis.is_moving(0.0)


# --- mode 2: INP and CLR, 0X (§10 0X, §10 DS) ---------------------------------------------

#: 0 from CW of ORG: pulse output ends at (3000 - 464) / 500 s (module docstring).
OUTPUT_ENDS = (3000 - 464) / 500


def test_mode_2_conventional_algorithm_waits_for_inp_then_clears() -> None:
    # 0X0 ⑤: after the 0S pulses wait for INP (here 50 ms), then CLR 100 µs, then done.
    setup = HomingSetup(mode=2, algorithm=0)
    axis, events = search(ORIGIN, CW_OF_ORG, setup, inp_delay=0.05)
    assert path(axis) == APPROACH
    assert [(e.kind, round(e.time, 6)) for e in events] == [
        (CLEAR, round(OUTPUT_ENDS + 0.05, 6)),
        (HOMED, round(OUTPUT_ENDS + 0.05, 6)),
    ]


def test_mode_2_new_algorithm_clears_at_recognition_and_waits_after_each_step() -> None:
    # 0X1 ②: CLR with the recognition stop (489 reached after (3000 - 489) / 500 s);
    # ③ INP after the 5-pulse step; ⑤ INP after the 0S pulses; no CLR at the end.
    setup = HomingSetup(mode=2, algorithm=1)
    axis, events = search(ORIGIN, CW_OF_ORG, setup, inp_delay=0.05)
    assert path(axis) == APPROACH
    assert [(e.kind, round(e.time, 6)) for e in events] == [
        (CLEAR, round((3000 - 489) / 500, 6)),
        (HOMED, round(OUTPUT_ENDS + 2 * 0.05, 6)),
    ]


def test_mode_2_inp_timeout_is_a_limit_error() -> None:
    # §10 0X (注意): no INP within 3 s: CLR 100 µs, limit error, the search ends.
    setup = HomingSetup(mode=2)
    axis, events = search(ORIGIN, CW_OF_ORG, setup, inp_delay=5.0)
    assert [(e.kind, round(e.time, 6)) for e in events] == [
        (CLEAR, round(OUTPUT_ENDS + 3.0, 6)),
        (LIMIT, round(OUTPUT_ENDS + 3.0, 6)),
    ]
    assert axis.counter(10_000.0) == 464 - CW_OF_ORG  # no new origin


def test_mode_0_ignores_inp_and_clr() -> None:
    _, events = search(ORIGIN, CW_OF_ORG, inp_delay=5.0)
    assert events == [AxisEvent(pytest.approx(OUTPUT_ENDS), HOMED)]  # type: ignore[arg-type]


def test_mode_2_0z_clears_after_the_final_five_pulses() -> None:
    # §10 DS ①: 0Z - CLR once the final 5 pulses are out.
    _, events = search(Z_PHASE, CW_OF_ORG, HomingSetup(mode=2), **Z_SCENE)
    assert [e.kind for e in events] == [CLEAR, HOMED]
    assert events[0].time == events[1].time


# --- stopping a search ----------------------------------------------------------------------


def test_s_abandons_the_search() -> None:
    axis = Axis(AxisScene(start=CW_OF_ORG))
    axis.home(0.0, ORIGIN, SETUP, DEFAULTS)
    assert axis.is_moving(0.5)
    assert axis.homing
    axis.stop(1.0)
    assert axis.advance(10_000.0) == []
    assert axis.counter(10_000.0) == -500  # 1 s CCW at fL; no new origin
    assert not axis.homing


def test_ss_abandons_the_search_on_the_next_pulse() -> None:
    axis = Axis(AxisScene(start=CW_OF_ORG))
    axis.home(0.0, ORIGIN, SETUP, DEFAULTS)
    axis.slow_stop(1.001)  # already at Low speed: the next pulse (501) is the last
    assert axis.advance(10_000.0) == []
    assert axis.counter(10_000.0) == -501


def test_emergency_during_a_search() -> None:
    axis = Axis(AxisScene(start=CW_OF_ORG))
    axis.home(0.0, HIGH_A, SETUP, DEFAULTS)
    axis.emergency(0.1)
    assert [e.kind for e in axis.advance(10_000.0)] == [AxisEventKind.EMERGENCY]
    assert not axis.homing


def test_forced_org_is_found_where_it_is_forced() -> None:
    # A fault: ORG forced ON half-way; the search takes it for the sensor (after 20 ms).
    axis = Axis(AxisScene(start=CW_OF_ORG))
    axis.home(0.0, ORIGIN, SETUP, DEFAULTS)
    axis.force(SensorName.ORG, True, now=1.0)  # at 2500
    events = axis.advance(10_000.0)
    assert [e.kind for e in events] == [HOMED]
    assert axis.mechanical(10_000.0) == 2500 - 10 - 5 - 20


def test_speed_commands_do_not_touch_a_search() -> None:
    # H / L are for 7 / 8 (§10 H, L); a search keeps the speeds it started with (our choice).
    axis = Axis(AxisScene(start=CW_OF_ORG))
    axis.home(0.0, ORIGIN, SETUP, DEFAULTS)
    axis.to_high(1.0)
    axis.retune(1.0, SpeedSettings(ol=1000))
    assert axis.speed(2.0) == -500
    assert_homed_at(axis, axis.advance(10_000.0), 464)
