"""Motion of one simulated RC-233 axis over simulated time: moves, jogs, stops, speed changes.

A ``MotionProfile`` is a piecewise constant-jerk curve (``profile.Segment``s, contiguous in
time) plus what the controller needs to edit it: the target of a move, the level of a jog,
the settings in force, the armed N points and the moment the final deceleration starts.
Commands arriving at any time t (S, SS, H, L, OH/OL/OS/OX changes) return a new profile that
keeps the curve up to t and replaces the rest. Everything counts pulses done since the motion
started (always >= 0); the simulator adds them to the position in the direction of motion.

No clocks, no I/O: time is a float of simulated seconds. Positions are whole pulses; a move
ends exactly on its target. The curves are laid out by ``planning``. Ambiguities and our
choices: docs/manual-notes.md.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, replace
from enum import StrEnum
from functools import cached_property

# An N point is the same value the N{pn} query reports; one type serves both.
from gateway.protocol.reply_values import SpeedPoint
from gateway.protocol.speeds import SpeedSettings
from gateway.sim.planning import (
    BISECTION_STEPS,
    cut_at_time,
    move_segments,
    place,
    plan_tail,
    point_triggers,
)
from gateway.sim.profile import Segment, ramp

__all__ = [
    "EPSILON",
    "MotionKind",
    "MotionProfile",
    "SpeedLevel",
    "SpeedPoint",
    "plan_jog",
    "plan_move",
    "plan_pulse",
]

#: Slack when turning a continuous position into whole pulses: float sums of ramps and
#: cruises may land a hair below the integer they add up to.
EPSILON = 1e-6


class MotionKind(StrEnum):
    """What started the motion."""

    MOVE = "move"  # a move of N pulses at High speed: 1, 3, 4, 5, B, B+(-); 7*/8* one pulse
    JOG = "jog"  # continuous rotation 7 / 8, at Low speed until H


class SpeedLevel(StrEnum):
    """Speed a jog runs at (§10 H, L); a move is always HIGH."""

    LOW = "low"
    HIGH = "high"


@dataclass(frozen=True)
class MotionProfile:
    """One motion of one axis: where it is at any time, and how commands change it.

    ``end`` is the pulse count the motion ends on (the move's target, or where S/SS stopped
    it); None while a jog runs without end. ``decel_start`` is when a move's final ramp
    begins: from then on speed changes no longer apply to it. ``stopping`` is set by S / SS.
    """

    segments: tuple[Segment, ...]
    settings: SpeedSettings
    kind: MotionKind
    level: SpeedLevel = SpeedLevel.HIGH
    distance: int | None = None
    end: int | None = None
    decel_start: float = math.inf
    points: tuple[SpeedPoint, ...] = ()
    stopping: bool = False

    @cached_property
    def _starts(self) -> tuple[float, ...]:
        return tuple(segment.t0 for segment in self.segments)

    @property
    def start(self) -> float:
        """When the motion started."""
        return self.segments[0].t0

    @property
    def end_time(self) -> float:
        """When the last pulse is out and the motion is over (``inf`` for a running jog)."""
        return math.inf if self.end is None else self.segments[-1].end_time

    @property
    def duration(self) -> float:
        """Length of the motion [s] (``inf`` for a running jog)."""
        return self.end_time - self.start

    def is_moving(self, t: float) -> bool:
        """Whether the axis is turning at time t."""
        return self.start <= t < self.end_time

    def _segment_at(self, t: float) -> Segment:
        index = max(0, bisect_right(self._starts, t) - 1)
        return self.segments[index]

    def position(self, t: float) -> int:
        """Whole pulses done at time t: monotonic, and exactly ``end`` once the motion is over."""
        if self.end is not None and t >= self.end_time:
            return self.end
        if t <= self.start:
            return 0
        done = max(0, math.floor(self._segment_at(t).position(t) + EPSILON))
        return done if self.end is None else min(done, self.end)

    def speed(self, t: float) -> float:
        """Pulse rate [pps] at time t (0 before the start and after the end)."""
        if not self.is_moving(t):
            return 0.0
        return self._segment_at(t).speed(t)

    def acceleration(self, t: float) -> float:
        """Rate of change of the pulse rate [pps/s] at time t (0 when not moving)."""
        if not self.is_moving(t):
            return 0.0
        return self._segment_at(t).acceleration(t)

    def time_at(self, pulses: int) -> float | None:
        """Earliest time at which ``position`` reaches ``pulses``; None if it never does.

        For sensors: when does the axis pass pulse k. ``position(time_at(k)) >= k``.
        """
        if pulses <= 0:
            return self.start
        if self.end is not None and pulses > self.end:
            return None
        last = len(self.segments) - 1
        index = next(
            (
                i
                for i, s in enumerate(self.segments[:last])
                if s.position(s.end_time) + EPSILON >= pulses
            ),
            last,
        )
        segment = self.segments[index]
        lo = segment.t0
        if index < last:
            hi = segment.end_time
        elif self.end is not None:
            hi = self.end_time
        else:  # endless cruise of a jog: linear, one pulse of margin
            hi = segment.t0 + (pulses - segment.p0 + 1) / segment.v0
        for _ in range(BISECTION_STEPS):
            mid = (lo + hi) / 2
            if not lo < mid < hi:
                break
            if self.position(mid) >= pulses:
                hi = mid
            else:
                lo = mid
        return hi

    def _state(self, t: float) -> tuple[float, float, float, float]:
        segment = self._segment_at(t)
        return t, segment.position(t), segment.speed(t), segment.acceleration(t)

    def stop(self, t: float) -> MotionProfile:
        """S (§10 S): pulse output stops at once; the position stays what it is at t."""
        if t >= self.end_time:
            return self
        t = max(t, self.start)
        return replace(
            self,
            segments=tuple(cut_at_time(self.segments, t)),
            end=self.position(t),
            decel_start=min(self.decel_start, t),
            stopping=True,
        )

    def slow_stop(self, t: float) -> MotionProfile:
        """SS (§10 SS): ramp down to Low speed along the usual ramp, then stop.

        The motor stops on the next whole pulse after reaching fL. A move already in its final
        ramp is left alone: that ramp ends at fL on the target anyway.
        """
        if t >= self.end_time or self.stopping:
            return self
        t = max(t, self.start)
        if self.kind is MotionKind.MOVE and t >= self.decel_start:
            return replace(self, stopping=True)
        t, p, v, a = self._state(t)
        fl = self.settings.fl
        head, (t1, p1, v1) = place(t, p, v, ramp(v, fl, self.settings, a) if v > fl else [])
        last_pulse = math.ceil(p1 - EPSILON)
        if self.distance is not None:  # never past the target (cannot happen by construction)
            last_pulse = min(last_pulse, self.distance)
        creep = Segment(t1, max(0.0, (last_pulse - p1) / v1), p1, v1)
        return replace(
            self,
            segments=(*cut_at_time(self.segments, t), *head, creep),
            end=last_pulse,
            decel_start=t,
            stopping=True,
        )

    def to_high(self, t: float) -> MotionProfile:
        """H (§10 H): a 7/8 jog ramps up to High speed; nothing else is affected."""
        return self._retarget(t, SpeedLevel.HIGH)

    def to_low(self, t: float) -> MotionProfile:
        """L (§10 L): a 7/8 jog ramps down to Low speed; nothing else is affected."""
        return self._retarget(t, SpeedLevel.LOW)

    def _retarget(self, t: float, level: SpeedLevel) -> MotionProfile:
        if self.kind is not MotionKind.JOG or self.stopping or t >= self.end_time:
            return self
        return self._jog_towards(t, level, self.settings, 1.0)

    def _jog_towards(
        self, t: float, level: SpeedLevel, settings: SpeedSettings, jump: float
    ) -> MotionProfile:
        t, p, v, a = self._state(max(t, self.start))
        v *= jump
        target = settings.fh if level is SpeedLevel.HIGH else settings.fl
        head, (t1, p1, _) = place(t, p, v, ramp(v, target, settings, a))
        cruise = Segment(t1, math.inf, p1, target)
        return replace(
            self,
            segments=(*cut_at_time(self.segments, t), *head, cruise),
            settings=settings,
            level=level,
        )

    def with_settings(self, t: float, settings: SpeedSettings) -> MotionProfile:
        """New OH / OL / OS / OX while moving, from time t (§10 OH, OL, OS, OX).

        OC = 0 only: a jog ramps to the new speed of its level (T = |Δ data| / 4,915,200 × OS);
        a move heads for the new High speed and stops at the new Low speed (T1, T2 of §10 OH);
        a new OX changes the speed at once, without ramp (§10 OX). With OC != 0 the manual
        guarantees nothing: the running motion is kept and the values apply to the next one.
        A move already in its final ramp, or stopping, keeps its course.
        """
        keep = replace(self, settings=settings)
        if t >= self.end_time or self.stopping or settings.oc != 0 or self.settings.oc != 0:
            return keep
        jump = self.settings.ox_internal / settings.ox_internal
        if self.kind is MotionKind.JOG:
            return self._jog_towards(t, self.level, settings, jump)
        if t >= self.decel_start or self.distance is None:
            return keep
        t, p, v, _ = self._state(max(t, self.start))
        triggers = point_triggers(self.distance, self.points)
        fired = [trigger for trigger in triggers if trigger[0] <= p]
        tail, decel_start = plan_tail(
            (t, p, v * jump),
            settings,
            self.distance,
            fired[-1][1] if fired else None,
            [trigger for trigger in triggers if trigger[0] > p],
        )
        return replace(
            keep, segments=(*cut_at_time(self.segments, t), *tail), decel_start=decel_start
        )


def plan_move(
    settings: SpeedSettings,
    distance: int,
    *,
    start: float = 0.0,
    points: tuple[SpeedPoint, ...] = (),
) -> MotionProfile:
    """A move of ``distance`` pulses at High speed (commands 1, 3, 4, 5, B, B+(-)), from ``start``.

    Starts at fL, ramps to fH, cruises, ramps down to fL and stops on the target (§7):
    trapezoid for OC = 0, S ramps for OC > 0, turning at fH' when too short (§7-3). ``points``
    are the N points armed by NS (§10 N), which need OC = 0.
    """
    if distance < 0:
        raise ValueError(f"distance {distance} is negative; give pulses to go")
    if points and settings.oc != 0:
        raise ValueError("N speed-change points need OC = 0 (§10 N)")
    segments, decel_start = move_segments(settings, distance, start, points)
    return MotionProfile(
        segments=tuple(segments),
        settings=settings,
        kind=MotionKind.MOVE,
        distance=distance,
        end=distance,
        decel_start=decel_start,
        points=points,
    )


def plan_jog(settings: SpeedSettings, *, start: float = 0.0) -> MotionProfile:
    """Continuous rotation 7 / 8 (§10 7, 8): at Low speed from the start, until S or SS."""
    return MotionProfile(
        segments=(Segment(start, math.inf, 0.0, settings.fl),),
        settings=settings,
        kind=MotionKind.JOG,
        level=SpeedLevel.LOW,
    )


def plan_pulse(settings: SpeedSettings, *, start: float = 0.0) -> MotionProfile:
    """One pulse 7* / 8* (§10 7*, 8*): one period of the Low speed, no ramp."""
    return MotionProfile(
        segments=(Segment(start, 1 / settings.fl, 0.0, settings.fl),),
        settings=settings,
        kind=MotionKind.MOVE,
        distance=1,
        end=1,
        decel_start=start,
    )
