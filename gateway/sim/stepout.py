"""Step-out detection while a motor turns: the slotted dog (modes 0, 2) or the encoder
(mode 1, and mode 0 with ``QSE``) (§10 Q, 0Q, QS, QSE, QE; §13-2).

Which method (§10 QS 解説 table): mode 0 ``Q``/``0Q`` (the dog on EZ) or ``QSE`` (the
encoder), mode 1 ``QE`` (the encoder), mode 2 ``Q``/``0Q``; ``QS`` turns detection on per motor.

Dog (docs/manual-notes.md, "Step-out detection"): ``0Q`` puts position 0 in the middle of a
dog (§10 0Q), the dog is ON for half of each period of ``Q`` pulses, and the sensor must read
ON at position 0 (§10 Q 重要な注意事項). So the controller expects the sensor ON where the
position counter is a multiple of the period (the middles of the dogs) and OFF half a period
further (the middles of the gaps); a reading that differs there is a step-out. Mechanics that
lag by more than a quarter period are caught; readings near the edges, which 0Q is there to
keep away from (§10 0Q 解説), are never looked at.

Encoder: the deviation between the pulses output and what the encoder counted is checked
every 50 ms while the motor turns (§10 QE 備考, §13-2), from the start of pulse output, and
once more when pulse output ends; over ± 4 × 2^QE output pulses (§10 QE table) is a step-out.
The simulator's mechanics follow the pulses exactly except for lost pulses (``slip``), so the
deviation is the pulses lost since the motion started.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gateway.protocol.reply_values import MotorPair
from gateway.sim.memory import Settings
from gateway.sim.scene import EzWiring, SensorName
from gateway.sim.watch import Track

__all__ = [
    "CHECK_PERIOD",
    "DogGuard",
    "EncoderGuard",
    "Guard",
    "guard_for",
    "rest_guard_for",
    "window",
]

#: §10 QE 備考: the deviation is checked every 50 ms.
CHECK_PERIOD = 0.050
#: A dog scan gives up after this many checks (the pattern repeats long before).
MAX_CHECKS = 20_000


def window(qe: int) -> int:
    """§10 QE table: DT 0-9 -> ± 4, 8, 16, ..., 2,048 output pulses."""
    return 4 << qe


def _digit(pair: MotorPair, motor: int) -> int:
    return pair.motor1 if motor == 1 else pair.motor2


@dataclass(frozen=True)
class DogGuard:
    """The slotted dog: ON expected at multiples of ``period``, OFF half a period further."""

    period: int  # Q s1

    def due(self, track: Track, counter_origin: int) -> float:
        """When along ``track`` a check reads the sensor wrong (``inf``: never).

        ``counter_origin`` is the position counter at pulse 0 of the run; checks are made on
        the pulses still to come (after ``track.base_k``).
        """
        period = self.period
        lo = track.base_k + 1
        scene = track.reader.scene
        pattern = scene.dog_period if scene.ez is EzWiring.DOG else scene.z_period
        span = min(math.lcm(period, pattern) + period, MAX_CHECKS // 2 * period)
        hi = lo + span if track.k_max is None else min(track.k_max, lo + span)
        sign = int(track.direction)
        firsts = sorted(
            (lo + (sign * (residue - counter_origin) - lo) % period, want)
            for residue, want in ((0, True), (period // 2, False))
        )
        for base in range(0, hi - lo + 1, period):
            for first, want in firsts:
                k = first + base
                if k > hi:
                    return math.inf
                if track.reads(SensorName.EZ, k) != want:
                    return track.time_of(k)
        return math.inf


@dataclass(frozen=True)
class EncoderGuard:
    """The encoder: a deviation over ``window`` output pulses, seen on the 50 ms checks."""

    window: int

    def due(self, start: float, t: float, end: float, deviation: int) -> float:
        """When a motion started at ``start`` and ending at ``end`` sees ``deviation`` (from t)."""
        if abs(deviation) <= self.window:
            return math.inf
        tick = start + math.ceil((t - start) / CHECK_PERIOD - 1e-9) * CHECK_PERIOD
        return min(max(tick, t), end)


Guard = DogGuard | EncoderGuard


def guard_for(settings: Settings, motor: int) -> Guard | None:
    """The detection a motion of ``motor`` runs under, by mode, QS and QSE (§10 QS 解説)."""
    shared = settings.shared
    if not _digit(shared.step_out_detect, motor):
        return None
    if shared.mode == 1 or (shared.mode == 0 and _digit(shared.encoder_step_out, motor)):
        return EncoderGuard(window(shared.step_out_window))
    return DogGuard(settings.motors[motor].step_out_period)


def rest_guard_for(settings: Settings, motor: int, selected: int) -> EncoderGuard | None:
    """§10 QS setting 2 (mode 1 only): detection also at rest, for the selected motor."""
    shared = settings.shared
    if shared.mode != 1 or selected != motor or _digit(shared.step_out_detect, motor) != 2:
        return None
    return EncoderGuard(window(shared.step_out_window))
