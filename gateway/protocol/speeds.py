"""The speed settings of an RC-233 motor: its speed data to pulse rates and times (§7-1).

Pure arithmetic from the manual: speed data (OH, OL, OS, OC, OX) to physical quantities (pps,
pps/s, s), and the S-curve constraint the controller enforces when OH, OL or OC is set. The
simulator builds its ramps on these (``gateway.sim.profile``); the gateway answers
``GET /axes/{id}/speed`` with them and refuses what the controller would refuse.
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
    "SpeedSettings",
    "internal_ox",
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
