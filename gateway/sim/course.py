"""What runs on an axis (a motion laid on the scene, a search waiting for INP), what it leaves.

A ``Motion`` is a ``kinematics.MotionProfile`` started at a mechanical position and turning one
way; ``rearm`` works out ahead of time when it ends early, on its limit (§4-4), on the
condition of the search step it runs (``watch``) or on a step-out (``stepout``), so that the
``Axis`` settles it right then without polling. A ``Pause`` is a search or a follow-up waiting
(for INP in mode 2, §10 0X ⑤; for QJT in mode 1, §10 QJ ①). A ``FollowUp`` is what runs after
a plain motion that put all its pulses out (the INP wait of mode 2, the QJ adjustment of
mode 1). ``low_run`` is the profile of a counted run at Low speed. What comes of them:
``AxisEvent``s for the controller and ``Leg``s, the finished stretches of motion.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from enum import StrEnum

from gateway.protocol.speeds import SpeedSettings
from gateway.sim.homing import Ending, Halt, Run, Sequence
from gateway.sim.kinematics import MotionKind, MotionProfile, SpeedLevel
from gateway.sim.profile import Segment
from gateway.sim.scene import Direction, SensorName, SensorReader
from gateway.sim.stepout import DogGuard, Guard
from gateway.sim.watch import Track, Watch, watch

__all__ = [
    "AxisEvent",
    "AxisEventKind",
    "FollowUp",
    "Leg",
    "Motion",
    "Pause",
    "Task",
    "low_run",
]


class AxisEventKind(StrEnum):
    """What the controller must know about: it latches flags and outputs from these."""

    LIMIT = "limit"  # a limit stopped pulse output (or a search ended in an error stop)
    EMERGENCY = "emergency"  # EMS stopped the axis
    HOMED = "homed"  # a search ended; the counter is 0 at the origin
    CLEAR = "clear"  # mode 2: CLR output ON for 100 µs (§10 0X, DS ①-⑥)
    STEP_OUT = "step_out"  # a step-out was detected and stopped the motor (§10 Q, QE)


@dataclass(frozen=True)
class FollowUp:
    """What runs after a plain motion that put all its pulses out, with its speeds.

    ``plan`` is called when the pulses end (it may look at the axis then); the plan's steps
    run at ``settings``' Low speed (mode 1's QJO, §10 QJ form VIII).
    """

    plan: Callable[[], Sequence]
    settings: SpeedSettings


@dataclass(frozen=True)
class AxisEvent:
    """Something that happened at ``time`` (simulated seconds)."""

    time: float
    kind: AxisEventKind


@dataclass(frozen=True)
class Leg:
    """One finished stretch of motion, in mechanical positions (for tests and the display)."""

    start: float
    end: float
    start_position: int
    end_position: int


@dataclass
class Motion:
    """The running profile, where it started, and what ends it early (``due``, ``cause``)."""

    profile: MotionProfile
    direction: Direction
    origin: int  # mechanical position at pulse 0
    step: Run | None = None  # the search step it runs; None for 1-8, B and friends
    halting: bool = False  # Halt.TO_LOW: the condition was met, the ramp down runs
    due: float = math.inf
    cause: Ending = Ending.DONE
    width: int = 0
    armed: float = math.inf
    guard: Guard | None = None  # step-out detection of a plain motion (§10 QS)
    counter_origin: int = 0  # the position counter at pulse 0 (the dog's reference)
    slipped: int = 0  # pulses lost since it started (the encoder's deviation)
    after: FollowUp | None = None  # what runs once all its pulses are out

    @property
    def end_time(self) -> float:
        """When it ends: early (``due``) or at the end of its profile."""
        return min(self.due, self.profile.end_time)

    def position(self, t: float) -> int:
        """The mechanical position at time t."""
        return self.origin + self.direction * self.profile.position(t)

    def rearm(self, reader: SensorReader, t: float) -> None:
        """Work out when the motion ends early from t on: its limit or its step's condition."""
        profile = self.profile
        track = Track(
            reader,
            self.origin,
            self.direction,
            profile,
            base_k=profile.position(t),
            base_t=max(t, profile.start),
            k_max=profile.end,
        )
        limit = SensorName.CW_LIMIT if self.direction is Direction.CW else SensorName.CCW_LIMIT
        k_limit = track.first(limit, True, track.base_k)  # §4-4: ON stops pulse output
        t_limit = math.inf if k_limit is None else track.time_of(k_limit)
        if self.halting:
            seen = Watch(profile.segments[-1].t0)  # when the ramp down to fL ends
        elif self.step is not None:
            seen = watch(track if k_limit is None else replace(track, k_max=k_limit), self.step)
        else:
            seen = Watch()
        self.width, self.armed = seen.width, seen.armed
        t_out = self._step_out(track, k_limit, t)
        if t_limit <= min(seen.time, t_out):  # a tie goes to the limit
            self.due, self.cause = t_limit, Ending.LIMIT
        elif t_out <= seen.time:
            self.due, self.cause = t_out, Ending.STEP_OUT
        else:
            self.due, self.cause = seen.time, Ending.DONE

    def _step_out(self, track: Track, k_limit: int | None, t: float) -> float:
        """When the step-out detection stops this motion (``inf``: it does not)."""
        guard = self.guard
        if guard is None:
            return math.inf
        if isinstance(guard, DogGuard):
            bounded = track if k_limit is None else replace(track, k_max=k_limit)
            return guard.due(bounded, self.counter_origin)
        return guard.due(self.profile.start, t, self.profile.end_time, self.slipped)

    def expire(self, reader: SensorReader) -> Ending | None:
        """Its time is up (``end_time``): cut the profile there and tell how the motion ended.

        None: the condition of a ``Halt.TO_LOW`` step was met; the ramp down to fL starts and
        the motion goes on (rearmed) until fL is reached (0H).
        """
        t = self.end_time
        if self.due > self.profile.end_time:
            return Ending.DONE
        step = self.step
        if self.cause is Ending.DONE and step and step.halt is Halt.TO_LOW and not self.halting:
            self.profile, self.halting = self.profile.to_low(t), True
            self.rearm(reader, t)
            return None
        self.profile = self.profile.stop(t)
        return self.cause


@dataclass
class Pause:
    """A search or follow-up waiting: moving as far as the status flags go (§10 0X ⑤, QJ).

    ``inp_since`` (waits for INP only): when pulse output stopped; the wait ends with INP,
    or 3 s after that time (§10 0X 注意).
    """

    end_time: float
    ending: Ending
    inp_since: float | None = None


Task = Motion | Pause


def low_run(settings: SpeedSettings, start: float, pulses: int) -> MotionProfile:
    """``pulses`` pulses at Low speed, no ramp (fL is the start and stop speed, §7-1).

    A jog with an end, so that SS stops it on the next pulse like any Low speed motion.
    """
    fl = settings.fl
    return MotionProfile(
        segments=(Segment(start, pulses / fl, 0.0, fl),),
        settings=settings,
        kind=MotionKind.JOG,
        level=SpeedLevel.LOW,
        distance=pulses,
        end=pulses,
        decel_start=start,
    )
