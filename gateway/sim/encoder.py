"""Mode 1: the encoder count of one axis, and the QJ adjustment after a move (§7-4, §10 PA,
PB, QJ).

The encoder sees the mechanics (what the motor really did, lost pulses included). ``PB`` is
how many output pulses make one encoder pulse, ``PA`` the multiplication of the A/B phases
(§10 PB 解説: PB = pulses per motor turn / encoder resolution; §10 PA: × 1, 2, 4), so one
count is PB / PA output pulses. In mode 1 the position counter *is* the encoder count
(§7-4 ①): positions, targets and ``R`` are counts; speeds and homing pulses stay output pulses
(§7-4 ④).

The count is kept as ``count_ref + ⌊(mech - mech_ref) × PA / PB⌋``; a change of PA or PB
starts a new reference where the axis stands, so the count never jumps.

How many pulses a move outputs (docs/manual-notes.md, "Mode 1"): the number that brings the
count onto the target, reckoned from the count itself, so a move without lost pulses ends on
its target exactly.
"""

from __future__ import annotations

from collections.abc import Callable, Generator
from dataclasses import dataclass

from gateway.sim.homing import Action, Ending, Finish, Outcome, Run, Until, Wait
from gateway.sim.scene import Direction

__all__ = ["ADJUST_UNIT", "POSITION_LIMIT", "Encoder", "adjust_plan", "within_rule"]

#: §7-4 ②, §10 PA/PB: |pp × PB / PA| must stay below 8,388,608 (2^23).
POSITION_LIMIT = 8_388_608
#: §10 QJ form IV: QJT is counted in 10 ms.
ADJUST_UNIT = 0.010


def within_rule(position: int, pa: int, pb: int) -> bool:
    """§7-4 ②: |position × PB / PA| < 8,388,608 (exact, in integers)."""
    return abs(position) * pb < POSITION_LIMIT * pa


def _ceil_div(a: int, b: int) -> int:
    return -(-a // b)


@dataclass
class Encoder:
    """The encoder count of one axis as a function of its mechanical position."""

    pa: int = 1  # §16 defaults
    pb: int = 10
    mech_ref: int = 0
    count_ref: int = 0

    def count(self, mech: int) -> int:
        """The count with the axis at mechanical position ``mech``."""
        return self.count_ref + (mech - self.mech_ref) * self.pa // self.pb

    def preset(self, mech: int, value: int) -> None:
        """The count reads ``value`` at ``mech`` (R in mode 1; 0 when a search ends)."""
        self.mech_ref, self.count_ref = mech, value

    def set_ratio(self, mech: int, pa: int, pb: int) -> None:
        """New PA / PB from the axis standing at ``mech`` on; the count there stays."""
        if (pa, pb) != (self.pa, self.pb):
            self.count_ref, self.mech_ref = self.count(mech), mech
            self.pa, self.pb = pa, pb

    def first_reaching(self, count: int) -> int:
        """The lowest mechanical position where the count is ``count`` or more."""
        return self.mech_ref + _ceil_div((count - self.count_ref) * self.pb, self.pa)

    def landing(self, here: int, target: int) -> int:
        """Where a move from ``here`` stops so that the count reads ``target``.

        CW: the first position reading ``target``; CCW: the last one (a count is a band of
        PB / PA positions, entered from one side or the other).
        """
        if target > self.count(here):
            return self.first_reaching(target)
        if target < self.count(here):
            return self.first_reaching(target + 1) - 1
        return here


def adjust_plan(
    encoder: Encoder,
    here: Callable[[], int],
    target: int,
    wait: float,
    limit_pulses: int,
) -> Generator[Action, Outcome, None]:
    """§10 QJ ①-④: after a move, correct the count towards ``target`` (a search-like plan).

    ① wait QJT; ② no deviation: done; otherwise turn towards the target at the adjust speed
    (the follow-up's Low speed); ③ stop where the count has gone past the target, with a
    limit error if the limit in that direction stops the motor first (unless the count is
    already past) or after ``limit_pulses`` (QJA) pulses; ④ back one pulse at a time until
    the count equals the target or passes it again. One pulse at a time at the adjust speed
    takes the same time as a run of those pulses at that speed, so ④ is one run.
    """
    yield Wait(wait)
    position = here()
    count = encoder.count(position)
    if count == target:
        return
    forward = Direction.CW if target > count else Direction.CCW
    if forward is Direction.CW:
        past = encoder.first_reaching(target + 1)  # the first count above the target
        back_to = past - 1  # the last position with the count at or below the target
    else:
        past = encoder.first_reaching(target) - 1  # the first count below the target
        back_to = past + 1
    needed = abs(past - position)
    yield Run(forward, Until.DISTANCE, min(needed, limit_pulses))
    position = here()
    if (encoder.count(position) - target) * forward <= 0:
        yield Finish(False)  # the limit sensor, or QJA pulses without reaching the target
        return
    back = abs(position - back_to)
    if back:
        out = yield Run(Direction(-forward), Until.DISTANCE, back)
        if out.ending is not Ending.DONE:
            yield Finish(False)
