"""The sensor watches of an origin search: when a run's condition is met on its way.

A search step runs until a sensor condition (``homing.Until``); ``watch`` works out when along
a ``Track`` (the run's profile laid on the scene) the condition is met, so that the ``Axis``
can end the step there, ahead of time and without polling.

Sensor rules (§3-V, §10 0X, §10 0Z): ORG counts only if it stays ON for >= 6 pulses; a search
recognises ORG ON about 20 ms after it really turns ON (§10 0X ①). 0Z confirms ORG by 1 ms of
ON and samples EZ every 1 ms. Choices where the manual is silent: docs/manual-notes.md,
"Simulator axis, sensors and origin searches".
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

from gateway.sim.homing import Run, Until
from gateway.sim.kinematics import MotionProfile
from gateway.sim.scene import Direction, SensorName, SensorReader

__all__ = ["Track", "Watch", "watch"]

#: §3-V: ORG must stay ON for at least this many pulses to be recognised.
ORG_MIN_PULSES = 6
#: §10 0X ①: ORG ON is recognised about 20 ms after it really turns ON.
ORG_DELAY = 0.020
#: §10 0Z: ORG is confirmed by 1 ms of ON; EZ is sampled every 1 ms.
SAMPLE = 0.001
#: Delays land exactly on pulse instants (20 ms at 500 pps is 10 pulses); a pulse due at the
#: very moment of a recognition is still output, whatever float rounding says.
TIE = 1e-9
#: Scans of an endless run give up this far ahead (the counter is 24 bits wide, §10 EP).
MAX_SCAN = 1 << 24


@dataclass(frozen=True)
class Track:
    """The path of one run: pulse k of ``profile`` puts the axis at origin + direction × k.

    Scans start at ``base_k`` (reached at ``base_t``) and never pass ``k_max`` (the run's end,
    or the pulse where a limit stops it). A sensor ON at ``base_k`` is ON "at the start".
    """

    reader: SensorReader
    origin: int
    direction: Direction
    profile: MotionProfile
    base_k: int
    base_t: float
    k_max: int | None

    def time_of(self, k: int) -> float:
        """When pulse k is out (``inf`` if this run never gets there)."""
        if self.k_max is not None and k > self.k_max:
            return math.inf
        if k <= self.base_k:
            return self.base_t
        found = self.profile.time_at(k)
        return math.inf if found is None else found

    def reads(self, sensor: SensorName, k: int) -> bool:
        """The sensor's reading at pulse k."""
        return self.reader.reads(sensor, self.origin + self.direction * k)

    def change_after(self, sensor: SensorName, k: int) -> int | None:
        """The first pulse after k where the reading differs from pulse k's; None: never."""
        position = self.origin + self.direction * k
        found = self.reader.next_change(sensor, position, self.direction)
        return None if found is None else k + abs(found - position)

    def first(self, sensor: SensorName, want: bool, k: int) -> int | None:
        """The first pulse >= k where the sensor reads ``want``, within reach."""
        bound = self.base_k + MAX_SCAN if self.k_max is None else self.k_max
        while k <= bound:
            if self.reads(sensor, k) == want:
                return k
            found = self.change_after(sensor, k)
            if found is None:
                return None
            k = found
        return None


@dataclass(frozen=True)
class Watch:
    """When a run's condition is met (``inf``: not on this run), with what it measured."""

    time: float = math.inf
    width: int = 0
    armed: float = math.inf  # Z_PHASE: when ORG was confirmed


def watch(track: Track, run: Run) -> Watch:
    """When ``run``'s condition is met along ``track``."""
    if run.until is Until.ORG_ON:
        for k_on, _ in _org_windows(track):
            if k_on == track.base_k:
                return Watch(track.base_t + ORG_DELAY + TIE)
            six = track.time_of(k_on + ORG_MIN_PULSES - 1)
            return Watch(max(track.time_of(k_on) + ORG_DELAY + TIE, six))
    elif run.until is Until.ORG_PASSED:
        for _, k_off in _org_windows(track):
            return Watch() if k_off is None else Watch(track.time_of(k_off))
    elif run.until is Until.Z_PHASE:
        return _z_watch(track, run.pulses)
    elif run.until is Until.EZ_OFF:
        k = track.first(SensorName.EZ, False, track.base_k)
        return Watch() if k is None else Watch(track.time_of(k))
    elif run.until is Until.EZ_WIDTH:
        rise = track.first(SensorName.EZ, True, track.base_k)
        # §10 0Q form II: OFF readings within pd pulses of the rise are chatter, not the end.
        fall = None if rise is None else track.first(SensorName.EZ, False, rise + run.pulses)
        if rise is not None and fall is not None:
            return Watch(track.time_of(fall), width=fall - rise)
    return Watch()


def _org_windows(track: Track) -> Iterator[tuple[int, int | None]]:
    """The ORG ON stretches [k_on, k_off) that count (§3-V: >= 6 pulses; ON at the start does)."""
    k: int | None = track.base_k
    while k is not None and (k_on := track.first(SensorName.ORG, True, k)) is not None:
        k = track.change_after(SensorName.ORG, k_on)
        if k_on == track.base_k or k is None or k - k_on >= ORG_MIN_PULSES:
            yield k_on, k


def _sample(start: float, t: float) -> float:
    """The first 1 ms sample at or after t, on the grid that starts at ``start``."""
    return start if t <= start else start + math.ceil((t - start) / SAMPLE - 1e-9) * SAMPLE


def _z_watch(track: Track, count: int) -> Watch:
    """§10 0Z: ORG ON confirmed 1 ms later, then the ``count``-th Z pulse confirmed.

    From the ORG confirmation EZ is sampled every 1 ms; a Z pulse counts when two samples in a
    row read ON (figures A-F); then an OFF sample must come before the next can count.
    """
    for k_on, k_off in _org_windows(track):
        confirm = track.time_of(k_on) + SAMPLE + TIE
        if k_on != track.base_k:
            confirm = max(confirm, track.time_of(k_on + ORG_MIN_PULSES - 1))
        if math.isinf(confirm):
            return Watch()
        at_confirm = track.profile.position(confirm)
        if k_off is None or at_confirm < k_off:  # still ON 1 ms later
            break
    else:
        return Watch()
    k: int | None = at_confirm
    seen = 0
    off_from: float | None = None  # waiting for an OFF sample after this time
    while k is not None and (k_a := track.first(SensorName.EZ, True, k)) is not None:
        k = track.change_after(SensorName.EZ, k_a)
        t_on = max(confirm, track.time_of(k_a))
        t_off = math.inf if k is None else track.time_of(k)
        if off_from is not None and _sample(confirm, off_from) >= t_on:
            off_from = t_off  # the gap fell between two samples: still the same pulse
            continue
        off_from = None
        sample = _sample(confirm, t_on)
        if sample + SAMPLE < t_off:
            seen += 1
            if seen == count:
                return Watch(sample + SAMPLE, armed=confirm)
            off_from = t_off
    return Watch(armed=confirm)
