"""The shape of an RC-233 motor's speed ramps (§7-1, §10 OH/OL/OS/OC/OX).

The speed data and what they mean (pps, pps/s, s; the S-curve constraint) are
``gateway.protocol.speeds``, shared with the gateway; here the jerk-limited ramp between two
speeds, as a list of constant-jerk pieces. ``kinematics`` strings pieces into
motion profiles. Decisions on ambiguous points are in docs/manual-notes.md, "Simulator motion".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gateway.protocol.speeds import SpeedSettings

__all__ = ["Piece", "Segment", "ramp", "ramp_distance", "ramp_duration"]


@dataclass(frozen=True)
class Piece:
    """A stretch of a ramp with constant jerk: its length [s], start acceleration, jerk."""

    duration: float
    accel: float
    jerk: float = 0.0


@dataclass(frozen=True)
class Segment:
    """A placed piece: constant jerk from time ``t0`` for ``duration`` (``inf``: no end).

    x(τ) = p0 + v0 τ + a0 τ² / 2 + j τ³ / 6 with τ = t - t0, clamped to [0, duration].
    Positions are continuous pulses (float); ``kinematics`` turns them into whole pulses.
    """

    t0: float
    duration: float
    p0: float
    v0: float
    a0: float = 0.0
    jerk: float = 0.0

    @property
    def end_time(self) -> float:
        """When the segment ends (``inf`` for an endless one)."""
        return self.t0 + self.duration

    def _tau(self, t: float) -> float:
        return min(max(t - self.t0, 0.0), self.duration)

    def position(self, t: float) -> float:
        """Continuous pulse count at time t."""
        tau = self._tau(t)
        return self.p0 + tau * (self.v0 + tau * (self.a0 / 2 + tau * self.jerk / 6))

    def speed(self, t: float) -> float:
        """Speed [pps] at time t."""
        tau = self._tau(t)
        return self.v0 + tau * (self.a0 + tau * self.jerk / 2)

    def acceleration(self, t: float) -> float:
        """Acceleration [pps/s] at time t."""
        return self.a0 + self._tau(t) * self.jerk


def _s_pieces(dv: float, a: float, sign: float, alpha: float, jerk: float) -> list[Piece]:
    """Gain |dv| in direction ``sign`` starting at |acceleration| a <= α, ending at a = 0.

    Raise |a| with jerk j to a peak, hold it, lower it to 0 with jerk j. The peak is α when
    the gain allows (the linear part of §7-1's figure); otherwise the ramp is all S
    (a short move's fH', §7-3), with peak ap from (2 ap² - a²) / (2 j) = |dv|.
    """
    if dv <= 0:
        return []
    if (2 * alpha**2 - a**2) / (2 * jerk) <= dv:
        hold = (dv - (2 * alpha**2 - a**2) / (2 * jerk)) / alpha
        return [
            Piece((alpha - a) / jerk, sign * a, sign * jerk),
            Piece(hold, sign * alpha),
            Piece(alpha / jerk, sign * alpha, -sign * jerk),
        ]
    peak = math.sqrt(jerk * dv + a**2 / 2)
    return [
        Piece((peak - a) / jerk, sign * a, sign * jerk),
        Piece(peak / jerk, sign * peak, -sign * jerk),
    ]


def ramp(v0: float, v1: float, settings: SpeedSettings, a0: float = 0.0) -> list[Piece]:
    """Pieces that take the speed from v0 (acceleration a0) to v1 (acceleration 0).

    OC = 0: one piece at ±α (a trapezoid changes acceleration at once, so a0 does not
    matter). OC > 0: jerk-limited S ramp (§7-1 figure, §10 OC). When the motor is already
    accelerating towards v1 and can still stop accelerating before v1, it carries on; otherwise
    it first brings its acceleration to 0 (the jerk never reverses mid-way), then ramps.
    """
    alpha = settings.acceleration
    jerk = settings.jerk
    if math.isinf(jerk):
        if v1 == v0:
            return []
        return [Piece(abs(v1 - v0) / alpha, math.copysign(alpha, v1 - v0))]
    pieces: list[Piece] = []
    settle = v0 + a0 * abs(a0) / (2 * jerk)  # speed once the acceleration is back to 0
    if abs(a0) > alpha * (1 + 1e-9) or settle <= 0:
        # Only after settings changed under a running S ramp (not guaranteed by the manual,
        # §10 OH/OL): these settings cannot bring a0 back to 0 sensibly; start from 0 at once.
        a0 = 0.0
    if a0 != 0:
        if a0 * (v1 - v0) > 0 and (v1 - settle) * (v1 - v0) >= 0:
            return _s_pieces(abs(v1 - v0), abs(a0), math.copysign(1.0, a0), alpha, jerk)
        pieces.append(Piece(abs(a0) / jerk, a0, -math.copysign(jerk, a0)))
        v0 = settle
    return pieces + _s_pieces(abs(v1 - v0), 0.0, math.copysign(1.0, v1 - v0), alpha, jerk)


def ramp_duration(v0: float, v1: float, settings: SpeedSettings) -> float:
    """Length [s] of a ramp from v0 to v1 that starts and ends at acceleration 0.

    Between fL and fH this is tacc (§7-1); OC = 0 gives |Δ data| / 4,915,200 × OS (§10 OH).
    """
    return sum(piece.duration for piece in ramp(v0, v1, settings))


def ramp_distance(v0: float, v1: float, settings: SpeedSettings) -> float:
    """Pulses covered by that ramp: (v0 + v1) / 2 × duration.

    The S ramp is point-symmetric about its middle, so its mean speed is the mean of its ends,
    exactly as for the trapezoid (which gives §10 N's Pg = |v1² - v0²| / (32,768 × OX) × OS).
    """
    return (v0 + v1) / 2 * ramp_duration(v0, v1, settings)
