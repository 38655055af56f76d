"""How the curve of a motion is laid out: pieces placed end to end, cut short, planned ahead.

The building blocks of ``kinematics.MotionProfile``: constant-jerk pieces (``profile.Piece``)
placed one after the other into ``profile.Segment``s, segments cut at a time or at a position,
and the two ways a move is planned (``move_segments``, §7-3): the OC = 0 trapezoid with its N
speed-change points (``plan_tail``, §10 N) and the OC > 0 S-curve move (``s_curve_move``). Pure
arithmetic on simulated time; ambiguities and our choices: docs/manual-notes.md, "Simulator motion".
"""

from __future__ import annotations

import math
from dataclasses import replace

from gateway.protocol.reply_values import SpeedPoint
from gateway.protocol.speeds import SpeedSettings
from gateway.sim.profile import Piece, Segment, ramp, ramp_distance

__all__ = [
    "BISECTION_STEPS",
    "cut_at_position",
    "cut_at_time",
    "move_segments",
    "place",
    "plan_tail",
    "point_triggers",
    "s_curve_move",
    "trapezoid_pieces",
]

#: Bisection steps: enough to reach adjacent floats on any range of times or speeds.
BISECTION_STEPS = 200


def place(
    t: float, p: float, v: float, pieces: list[Piece]
) -> tuple[list[Segment], tuple[float, float, float]]:
    """Place pieces one after the other from state (t, p, v); return them and the end state."""
    segments: list[Segment] = []
    for piece in pieces:
        if piece.duration <= 0:
            continue
        segment = Segment(t, piece.duration, p, v, piece.accel, piece.jerk)
        segments.append(segment)
        t = segment.end_time
        p, v = segment.position(t), segment.speed(t)
    return segments, (t, p, v)


def cut_at_time(segments: tuple[Segment, ...], t: float) -> list[Segment]:
    """The segments up to time t (the one holding t shortened); never empty."""
    kept = [segment for segment in segments if segment.t0 < t]
    if not kept:
        return [replace(segments[0], duration=0.0)]
    last = kept[-1]
    kept[-1] = replace(last, duration=min(last.duration, t - last.t0))
    return kept


def cut_at_position(
    segments: list[Segment], x: float
) -> tuple[list[Segment], tuple[float, float, float]]:
    """The segments up to where the continuous position reaches x, and the state there."""
    index = next(
        (i for i, s in enumerate(segments) if s.position(s.end_time) >= x), len(segments) - 1
    )
    segment = segments[index]
    lo, hi = segment.t0, segment.end_time
    for _ in range(BISECTION_STEPS):
        mid = (lo + hi) / 2
        if not lo < mid < hi:
            break
        if segment.position(mid) >= x:
            hi = mid
        else:
            lo = mid
    cut = replace(segment, duration=hi - segment.t0)
    return [*segments[:index], cut], (hi, cut.position(hi), cut.speed(hi))


def _constant(v0: float, v1: float, alpha: float) -> Piece:
    """A trapezoid ramp piece from v0 to v1 at ±α."""
    return Piece(abs(v1 - v0) / alpha, math.copysign(alpha, v1 - v0))


def trapezoid_pieces(
    v: float, remaining: float, cruise: float, final: float, alpha: float
) -> tuple[list[Piece], list[Piece]]:
    """OC = 0: from speed v, cover ``remaining`` pulses heading for ``cruise``, end at ``final``.

    Returns the pieces before the final ramp and the final ramp. The final ramp starts when
    the pulses left equal the pulses it needs, |cruise² - final²| / (2α) (§10 N's Pg). When
    cruise and final ramps do not fit, the speed turns at a peak (or trough) between them
    (§7-3, triangle). When even the direct ramp v -> final does not fit (a speed change too
    close to the target), the motor ramps towards ``final`` and stops on the target
    at whatever speed it has reached: it never overshoots (docs/manual-notes.md, "Simulator
    motion").
    """
    d1 = abs(cruise**2 - v**2) / (2 * alpha)
    d2 = abs(cruise**2 - final**2) / (2 * alpha)
    if d1 + d2 <= remaining:
        hold = Piece((remaining - d1 - d2) / cruise, 0.0)
        return [_constant(v, cruise, alpha), hold], [_constant(cruise, final, alpha)]
    if abs(v**2 - final**2) / (2 * alpha) <= remaining:
        # Turning speed: the ramps v -> turn and turn -> final cover exactly `remaining`.
        sign = 1.0 if cruise > v else -1.0
        turn = math.sqrt(max(0.0, (v**2 + final**2) / 2 + sign * alpha * remaining))
        return [_constant(v, turn, alpha)], [_constant(turn, final, alpha)]
    reached = math.sqrt(max(0.0, v**2 + math.copysign(2 * alpha * remaining, final - v)))
    return [], [_constant(v, reached, alpha)]


def point_triggers(distance: int, points: tuple[SpeedPoint, ...]) -> list[tuple[float, int]]:
    """Positions (pulses done) where the N points fire, with their speed data (§10 N).

    A point fires once fewer than its remaining pulses are left, i.e. at pulse
    distance - remaining + 1, and only after the previous one fired; a point with 0 remaining
    never fires and stops the comparison; a move shorter than point 1 starts at its speed.
    """
    triggers: list[tuple[float, int]] = []
    previous = 0
    for point in points:
        position = max(previous, distance - point.remaining + 1)
        if point.remaining == 0 or position >= distance:
            break
        triggers.append((float(position), point.speed))
        previous = position
    return triggers


def plan_tail(
    state: tuple[float, float, float],
    settings: SpeedSettings,
    distance: int,
    cruise_data: int | None,
    pending: list[tuple[float, int]],
) -> tuple[list[Segment], float]:
    """OC = 0: the rest of a move from state (t, p, v); its segments and final-ramp start time.

    ``cruise_data`` is the speed data the move heads for (None: OH); ``pending`` the N points
    still to fire. A point that fires before the final ramp cuts the plan and heads for its
    speed; points that would fire once the final ramp has begun are ignored (§10 N 重要な注意
    事項 3 guarantees nothing when ramps overlap; docs/manual-notes.md, "Simulator motion").
    """
    t, p, v = state
    segments: list[Segment] = []
    queue = list(pending)
    while True:
        while queue and queue[0][0] <= p:
            cruise_data = queue.pop(0)[1]
        # Speed data 0 would never arrive; the slowest the generator makes is data 1.
        cruise = settings.fh if cruise_data is None else settings.speed(max(cruise_data, 1))
        before, final = trapezoid_pieces(
            v, distance - p, cruise, settings.fl, settings.acceleration
        )
        head, (t1, p1, v1) = place(t, p, v, before)
        if queue and queue[0][0] < p1:
            x, cruise_data = queue.pop(0)
            kept, (t, p, v) = cut_at_position(head, x)
            segments += kept
            continue
        tail, _ = place(t1, p1, v1, final)
        return segments + head + tail, t1


def s_curve_move(
    start: float, settings: SpeedSettings, distance: int
) -> tuple[list[Segment], float]:
    """OC > 0: fL -> S ramp -> cruise -> S ramp -> fL; a short move turns at fH' (§7-3)."""
    fl, peak = settings.fl, settings.fh
    if 2 * ramp_distance(fl, peak, settings) > distance:
        # fH' such that both ramps cover the move; bisection keeps g(lo) <= 0 < g(hi).
        lo, hi = fl, peak
        for _ in range(BISECTION_STEPS):
            mid = (lo + hi) / 2
            if mid in (lo, hi):
                break
            if 2 * ramp_distance(fl, mid, settings) > distance:
                hi = mid
            else:
                lo = mid
        peak = lo
    hold = max(0.0, (distance - 2 * ramp_distance(fl, peak, settings)) / peak)
    head, (t1, p1, v1) = place(start, 0.0, fl, [*ramp(fl, peak, settings), Piece(hold, 0.0)])
    tail, _ = place(t1, p1, v1, ramp(peak, fl, settings))
    return head + tail, t1


def move_segments(
    settings: SpeedSettings, distance: int, start: float, points: tuple[SpeedPoint, ...]
) -> tuple[list[Segment], float]:
    """A move of ``distance`` pulses from ``start``: its segments and final-ramp start time.

    Trapezoid (with the N ``points``) for OC = 0, S ramps for OC > 0 (§7-3); 0 pulses is an
    empty motion at ``start``.
    """
    if distance == 0:
        return [Segment(start, 0.0, 0.0, 0.0)], start
    if settings.oc == 0:
        return plan_tail(
            (start, 0.0, settings.fl), settings, distance, None, point_triggers(distance, points)
        )
    return s_curve_move(start, settings, distance)
