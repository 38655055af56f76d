"""Speed settings of an RC-233 motor and the shape of its speed ramps (§7-1, §10 OH/OL/OS/OC/OX).

Pure arithmetic: speed data (OH, OL, OS, OC, OX) to physical quantities (pps, pps/s, s), the
S-curve constraint the controller enforces when OH, OL or OC is set, and the jerk-limited ramp
between two speeds, as a list of constant-jerk pieces. ``kinematics`` strings pieces into
motion profiles. Decisions on ambiguous points are in docs/manual-notes.md, "Simulator motion".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "ACCELERATION_CONSTANT",
    "BASE_OX",
    "CHANGE_RAMP_CONSTANT",
    "OC_MAX",
    "OS_MAX",
    "OX_MAX",
    "OX_MIN",
    "SPEED_DATA_MAX",
    "S_RANGE_MAX",
    "TACC_CONSTANT",
    "Piece",
    "Segment",
    "SpeedSettings",
    "internal_ox",
    "ramp",
    "ramp_distance",
    "ramp_duration",
    "speed_constraint_violation",
]

#: Ranges of the settings (§10 OH, OL: 1-16,383; OS: 1-32,767; OC: 0-100 %; OX: 2-16,383).
SPEED_DATA_MAX = 16_383
OS_MAX = 32_767
OC_MAX = 100
OX_MIN = 2
OX_MAX = 16_383
#: OX at which one unit of speed data is 1 pps (§7-1: multiplier = 300 / OX).
BASE_OX = 300
#: α = 1,474,560,000 / (OX × OS) pps/s (§7-1, §10 OS).
ACCELERATION_CONSTANT = 1_474_560_000
#: tacc = |OH - OL| / (24,576 × (200 - OC)) × OS s (§7-1, §10 OS).
TACC_CONSTANT = 24_576
#: Ramp time of a speed change while moving = |Δ speed data| / 4,915,200 × OS s (§10 OH, OL, N);
#: 4,915,200 = 24,576 × 200, i.e. the tacc formula with OC = 0.
CHANGE_RAMP_CONSTANT = 4_915_200
#: Bound of the S-curve expression (OH - OL) / (2 × (200 - OC)) × OC (§7-1, §10 OC/OH/OL).
S_RANGE_MAX = 4_095


def internal_ox(ox: int) -> int:
    """The OX value the controller really uses: rounded down to a multiple of 4, at least 4.

    §7-1 table and §10 OX: "the internal speed data exists only in steps of 4"; 30 gives 28
    (×10.7, not ×10) and 2-7 give 4, which is also the ×75 cap on the multiplier (the RC-231
    allowed ×150).
    """
    return max(4, ox - ox % 4)


@dataclass(frozen=True)
class SpeedSettings:
    """The speed data of one motor (OH, OL, OS, OC) and the shared OX, with derived values.

    Defaults are the factory values of §16: OH 5000, OL 500, OS 300, OC 0, OX 300. Values
    outside the manual's ranges raise ``ValueError``; the S-curve constraint is separate
    (``constraint_violation``), because the controller checks it only when OH, OL or OC is set.
    """

    oh: int = 5000
    ol: int = 500
    os: int = 300
    oc: int = 0
    ox: int = 300

    def __post_init__(self) -> None:
        for name, value, lo, hi in (
            ("OH", self.oh, 1, SPEED_DATA_MAX),
            ("OL", self.ol, 1, SPEED_DATA_MAX),
            ("OS", self.os, 1, OS_MAX),
            ("OC", self.oc, 0, OC_MAX),
            ("OX", self.ox, OX_MIN, OX_MAX),
        ):
            if not lo <= value <= hi:
                raise ValueError(f"{name} {value} outside {lo}-{hi}")

    @property
    def ox_internal(self) -> int:
        """The quantised OX that fixes the frequency multiplier (§7-1 table)."""
        return internal_ox(self.ox)

    @property
    def multiplier(self) -> float:
        """Frequency multiplier 300 / OX' (§7-1), at most 75."""
        return BASE_OX / self.ox_internal

    def speed(self, data: int) -> float:
        """Pulse rate [pps] of a speed-data value (OH, OL, an N point): data × 300 / OX'."""
        return data * self.multiplier

    @property
    def fh(self) -> float:
        """High speed fH = OH × 300 / OX' [pps] (§7-1)."""
        return self.speed(self.oh)

    @property
    def fl(self) -> float:
        """Low speed fL = OL × 300 / OX' [pps] (§7-1): start and stop frequency of moves."""
        return self.speed(self.ol)

    @property
    def acceleration(self) -> float:
        """α = 1,474,560,000 / (OX' × OS) [pps/s] (§7-1, §10 OS).

        The quantised OX' is used, like in fH and fL: only then is α the slope that takes
        fL to fH in tacc (the manual's own tacc formula holds no OX at all).
        """
        return ACCELERATION_CONSTANT / (self.ox_internal * self.os)

    @property
    def tacc(self) -> float:
        """Time between fL and fH: |OH - OL| / (24,576 × (200 - OC)) × OS [s] (§7-1)."""
        return abs(self.oh - self.ol) / (TACC_CONSTANT * (200 - self.oc)) * self.os

    @property
    def ts(self) -> float:
        """Length of each S-shaped part of a ramp: OC = 2 × ts / tacc × 100 % (§7-1, §10 OC)."""
        return self.oc / 200 * self.tacc

    @property
    def s_range(self) -> float:
        """Speed data gained in one S-shaped part: |OH - OL| / (2 × (200 - OC)) × OC.

        This is the expression of the §7-1 constraint: at peak acceleration α, an S part of
        length ts gains α × ts / 2, which is this many speed-data units.
        """
        return abs(self.oh - self.ol) * self.oc / (2 * (200 - self.oc))

    @property
    def jerk(self) -> float:
        """Rate of change of acceleration in the S parts [pps/s²]; ``inf`` for a trapezoid.

        An S part reaches α from 0 in ts, so j = α / ts = α² / (2 × s_range in pps). Held as a
        property of the settings (not of one ramp), so a ramp between any two speeds (H, L,
        SS) has the same S parts as the fL-fH ramp.
        """
        gain = self.speed(1) * self.s_range
        if gain <= 0:
            return math.inf
        return self.acceleration**2 / (2 * gain)

    @property
    def constraint_violation(self) -> str | None:
        """The S-curve rule these settings break, or None (see ``speed_constraint_violation``)."""
        return speed_constraint_violation(self.oh, self.ol, self.oc)


def speed_constraint_violation(oh: int, ol: int, oc: int) -> str | None:
    """The S-curve rule that OH, OL and OC break, as text, or None when they are acceptable.

    §7-1 and §10 OC/OH/OL: X = (OH - OL) / (2 × (200 - OC)) × OC must be <= 4,095, <= 16,383 - OH
    and <= 16,383 - OL, otherwise setting OH, OL or OC is a command error and the old value
    stays. |OH - OL| is used: with the signed difference the third rule could never fail
    (see docs/manual-notes.md, "Simulator motion"). Compared in integers (X × 2 × (200 - OC)),
    so no rounding.
    """
    numerator = abs(oh - ol) * oc
    denominator = 2 * (200 - oc)
    x = numerator / denominator
    for bound, text in (
        (S_RANGE_MAX, "4,095"),
        (SPEED_DATA_MAX - oh, "16,383 - OH"),
        (SPEED_DATA_MAX - ol, "16,383 - OL"),
    ):
        if numerator > bound * denominator:
            return (
                f"S-curve range |OH - OL| / (2 x (200 - OC)) x OC = {x:g} "
                f"exceeds {text} = {bound} (OH {oh}, OL {ol}, OC {oc}; §7-1)"
            )
    return None


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
