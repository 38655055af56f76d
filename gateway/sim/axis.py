"""One simulated motor of an RC-233: how it moves, what its sensors read, how it finds home.

Lazy and time-driven: a motion is a ``kinematics.MotionProfile`` started at some time; nothing
happens between calls. ``advance(now)`` runs everything due up to ``now`` (motion ends, limit
stops, the next step of a search) and returns the events since the last call. Queries advance
to their ``now`` as well (their events wait for the next ``advance``). Time never goes back.

The axis keeps its mechanical position (scene coordinates, what sensors see) and the position
counter (what command 6 reports) apart: homing and ``R`` change the counter, ``slip`` (lost
pulses) the mechanics. Rules around the axis (command errors, modes, EP wrap, flags, EMS state)
belong to the controller. Choices where the manual is silent: docs/manual-notes.md,
"Simulator axis, sensors and origin searches".
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace
from enum import StrEnum

from gateway.protocol.reply_values import SensorBits, SensorLogic
from gateway.sim.homing import (
    INP_TIMEOUT,
    Ending,
    Finish,
    Halt,
    HomingMethod,
    HomingSetup,
    Outcome,
    PulseClr,
    Run,
    Sequence,
    Speed,
    Track,
    Until,
    WaitInp,
    Watch,
    plan,
    watch,
)
from gateway.sim.kinematics import (
    MotionKind,
    MotionProfile,
    SpeedLevel,
    SpeedPoint,
    plan_jog,
    plan_move,
    plan_pulse,
)
from gateway.sim.profile import Segment, SpeedSettings
from gateway.sim.scene import AxisScene, Direction, SensorName, SensorReader

__all__ = [
    "Axis",
    "AxisBusy",
    "AxisEvent",
    "AxisEventKind",
    "Direction",
    "HomingMethod",
    "HomingSetup",
    "Leg",
    "SensorName",
]

#: How many finished legs ``Axis.legs`` keeps.
LEGS_KEPT = 100


class AxisEventKind(StrEnum):
    """What the controller must know about: it latches flags and outputs from these."""

    LIMIT = "limit"  # a limit stopped pulse output (or a search ended in an error stop)
    EMERGENCY = "emergency"  # EMS stopped the axis
    HOMED = "homed"  # a search ended; the counter is 0 at the origin
    CLEAR = "clear"  # mode 2: CLR output ON for 100 µs during a search (§10 0X, DS ①)


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


class AxisBusy(RuntimeError):
    """A motion was started while the axis is still moving (the controller's command error)."""


@dataclass
class _Motion:
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

    @property
    def end_time(self) -> float:
        return min(self.due, self.profile.end_time)

    def position(self, t: float) -> int:
        return self.origin + self.direction * self.profile.position(t)


@dataclass
class _Pause:
    """A search waiting for INP (mode 2): moving as far as the status flags go (§10 0X ⑤)."""

    end_time: float
    ending: Ending


def _low_run(settings: SpeedSettings, start: float, pulses: int) -> MotionProfile:
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


class Axis:
    """One motor: motion, sensors and origin searches in simulated time."""

    def __init__(self, scene: AxisScene) -> None:
        self.scene = scene
        self._reader = SensorReader(scene)
        self._rest = scene.start  # mechanical position while nothing runs
        self._offset = -scene.start  # counter - mechanical position; 0 at power-on
        self._task: _Motion | _Pause | None = None
        self._sequence: Sequence | None = None
        self._homing_settings = SpeedSettings()
        self._events: list[AxisEvent] = []
        self._time = -math.inf
        self._legs: deque[Leg] = deque(maxlen=LEGS_KEPT)
        self.step_out_width = 0  # 0QW: ON width of the step-out sensor found by the last 0Q
        self.start_counter = 0  # the counter where the last motion command started (§10 2 II)

    # --- settings and faults -------------------------------------------------------------

    @property
    def logic(self) -> SensorLogic:
        """The EA sensor logic (the controller assigns it); applies from the last advance."""
        return self._reader.logic

    @logic.setter
    def logic(self, value: SensorLogic) -> None:
        self._reader.logic = value
        self._rearm(self._time)

    def force(self, sensor: SensorName, on: bool | None, now: float | None = None) -> None:
        """Fault injection: the sensor reads ``on`` whatever the scene; None gives it back.

        Takes effect at ``now`` (default: the last time the axis was advanced to).
        """
        t = self._time if now is None else now
        sensor = SensorName(sensor)  # a plain name from the control surface works too
        self._advance(t)
        if on is None:
            self._reader.forced.pop(sensor, None)
        else:
            self._reader.forced[sensor] = on
        self._rearm(t)

    def slip(self, now: float, pulses: int) -> None:
        """Lost pulses: the mechanics move by ``pulses`` (CW positive); the counter does not."""
        self._advance(now)
        if isinstance(self._task, _Motion):
            self._task.origin += pulses
        else:
            self._rest += pulses
        self._offset -= pulses
        self._rearm(now)

    # --- queries -------------------------------------------------------------------------

    def advance(self, now: float) -> list[AxisEvent]:
        """Run everything due up to ``now``; the events since the last call, in time order."""
        self._advance(now)
        events, self._events = self._events, []
        return events

    def is_moving(self, now: float) -> bool:
        """Status bit 0: pulses are going out (or a search is still under way)."""
        self._advance(now)
        return self._task is not None

    @property
    def homing(self) -> bool:
        """Whether an origin search is under way."""
        return self._sequence is not None

    def mechanical(self, now: float) -> int:
        """Where the axis really is, in scene coordinates."""
        self._advance(now)
        return self._task.position(now) if isinstance(self._task, _Motion) else self._rest

    def counter(self, now: float) -> int:
        """The position counter (unbounded; the controller wraps it to 24 bits for EP)."""
        return self.mechanical(now) + self._offset

    def speed(self, now: float) -> float:
        """Pulse rate [pps], negative when turning CCW."""
        self._advance(now)
        if not isinstance(self._task, _Motion):
            return 0.0
        return self._task.direction * self._task.profile.speed(now)

    def sensors(self, now: float) -> SensorBits:
        """The inputs as CL reports them, after the EA logic; EMS is the controller's bit."""
        position = self.mechanical(now)
        reads = self._reader.reads
        return SensorBits(
            cw_limit=reads(SensorName.CW_LIMIT, position),
            ccw_limit=reads(SensorName.CCW_LIMIT, position),
            org=reads(SensorName.ORG, position),
            step_out_sensor=reads(SensorName.EZ, position),
        )

    @property
    def legs(self) -> tuple[Leg, ...]:
        """The last finished stretches of motion, oldest first."""
        return tuple(self._legs)

    # --- commands ------------------------------------------------------------------------

    def preset(self, now: float, value: int) -> None:
        """R: the counter reads ``value`` here; the mechanics do not move."""
        self._offset = value - self.mechanical(now)

    def move(
        self,
        now: float,
        distance: int,
        settings: SpeedSettings,
        points: tuple[SpeedPoint, ...] = (),
    ) -> None:
        """1, 3, 4, 5, B, B+(-): ``distance`` pulses (signed, CW positive); 0 does nothing."""
        self._idle(now)
        if distance:
            direction = Direction.CW if distance > 0 else Direction.CCW
            profile = plan_move(settings, abs(distance), start=now, points=points)
            self._start(now, _Motion(profile, direction, self._rest))

    def jog(self, now: float, direction: Direction, settings: SpeedSettings) -> None:
        """7 / 8: turn at Low speed until S, SS or the limit (§10 7, 8)."""
        self._idle(now)
        self._start(now, _Motion(plan_jog(settings, start=now), direction, self._rest))

    def step(self, now: float, direction: Direction, settings: SpeedSettings) -> None:
        """7* / 8*: one pulse (§10 7*, 8*)."""
        self._idle(now)
        self._start(now, _Motion(plan_pulse(settings, start=now), direction, self._rest))

    def stop(self, now: float) -> None:
        """S: pulse output stops at once; a search is abandoned (§10 S, §10 0 注意点)."""
        self._advance(now)
        self._sequence = None
        if isinstance(self._task, _Motion):
            self._task.profile = self._task.profile.stop(now)
            self._settle(now)
        self._task = None

    def slow_stop(self, now: float) -> None:
        """SS: down to Low speed, then stop; a search is abandoned (§10 SS)."""
        self._advance(now)
        self._sequence = None
        task = self._task
        if isinstance(task, _Motion):
            task.step, task.halting = None, False
            task.profile = task.profile.slow_stop(now)
            self._rearm(now)
        else:
            self._task = None

    def to_high(self, now: float) -> None:
        """H: a 7/8 jog ramps up to High speed."""
        self._edit(now, lambda profile: profile.to_high(now))

    def to_low(self, now: float) -> None:
        """L: a 7/8 jog ramps down to Low speed."""
        self._edit(now, lambda profile: profile.to_low(now))

    def retune(self, now: float, settings: SpeedSettings) -> None:
        """OH, OL, OS, OX changed while moving (§10 OH ...); a search keeps its own speeds."""
        self._edit(now, lambda profile: profile.with_settings(now, settings))

    def home(
        self, now: float, method: HomingMethod, setup: HomingSetup, settings: SpeedSettings
    ) -> None:
        """Start an origin search; HOMED when the counter is 0 at the origin.

        0Q needs the step-out sensor ON where the axis stands (§10 0Q): ``ValueError`` if not.
        """
        self._idle(now)
        here = self._rest
        start = Outcome(
            org=self._reader.reads(SensorName.ORG, here),
            ez=self._reader.reads(SensorName.EZ, here),
        )
        if method is HomingMethod.STEP_OUT and not start.ez:
            raise ValueError("0Q needs the step-out sensor ON at the start (§10 0Q)")
        self._homing_settings = settings
        self._sequence = plan(method, setup, start)
        self._continue(now, None)
        self._advance(now)

    def emergency(self, now: float) -> None:
        """EMS turned ON: everything stops at once; an EMERGENCY event in any case."""
        self.stop(now)
        self._events.append(AxisEvent(now, AxisEventKind.EMERGENCY))

    # --- machinery -----------------------------------------------------------------------

    def _idle(self, now: float) -> None:
        """Refuse a new motion while one runs; note where the new one starts (§10 2 注意点)."""
        self._advance(now)
        if self._task is not None:
            raise AxisBusy("the axis is moving")
        self.start_counter = self._rest + self._offset

    def _edit(self, now: float, change: Callable[[MotionProfile], MotionProfile]) -> None:
        """Apply a speed command to a plain motion (searches keep their course)."""
        self._advance(now)
        task = self._task
        if isinstance(task, _Motion) and task.step is None:
            task.profile = change(task.profile)
            self._rearm(now)

    def _start(self, now: float, motion: _Motion) -> None:
        self._task = motion
        self._rearm(now)
        self._advance(now)

    def _advance(self, now: float) -> None:
        if now < self._time:
            raise ValueError(f"time went back from {self._time} to {now}")
        while self._task is not None and self._task.end_time <= now:
            self._finish(self._task)
        self._time = now

    def _rearm(self, t: float) -> None:
        """Work out when the running motion ends early: its limit or its step's condition."""
        task = self._task
        if not isinstance(task, _Motion):
            return
        profile = task.profile
        track = Track(
            self._reader,
            task.origin,
            task.direction,
            profile,
            base_k=profile.position(t),
            base_t=max(t, profile.start),
            k_max=profile.end,
        )
        limit = SensorName.CW_LIMIT if task.direction is Direction.CW else SensorName.CCW_LIMIT
        k_limit = track.first(limit, True, track.base_k)  # §4-4: ON stops pulse output
        t_limit = math.inf if k_limit is None else track.time_of(k_limit)
        if task.halting:
            seen = Watch(profile.segments[-1].t0)  # when the ramp down to fL ends
        elif task.step is not None:
            seen = watch(track if k_limit is None else replace(track, k_max=k_limit), task.step)
        else:
            seen = Watch()
        task.width, task.armed = seen.width, seen.armed
        if t_limit <= seen.time:  # a tie goes to the limit
            task.due, task.cause = t_limit, Ending.LIMIT
        else:
            task.due, task.cause = seen.time, Ending.DONE

    def _finish(self, task: _Motion | _Pause) -> None:
        """The running task's time is up: settle it and go on with the search, if any."""
        t = task.end_time
        if isinstance(task, _Pause):
            self._task = None
            self._continue(t, self._outcome(task.ending))
            return
        ending = Ending.DONE
        if task.due <= task.profile.end_time:
            ending = task.cause
            step = task.step
            if ending is Ending.DONE and step and step.halt is Halt.TO_LOW and not task.halting:
                task.profile, task.halting = task.profile.to_low(t), True
                self._rearm(t)
                return
            task.profile = task.profile.stop(t)
        self._settle(t)
        self._task = None
        if task.step is not None and task.step.until is Until.EZ_WIDTH:
            self.step_out_width = task.width  # 0QW (§10 0Q form IV)
        if task.step is None:
            if ending is Ending.LIMIT:
                self._events.append(AxisEvent(t, AxisEventKind.LIMIT))
            return
        self._continue(t, self._outcome(ending, task))

    def _settle(self, t: float) -> None:
        task = self._task
        assert isinstance(task, _Motion)
        self._rest = task.position(t)
        self._legs.append(Leg(task.profile.start, t, task.origin, self._rest))

    def _outcome(self, ending: Ending, task: _Motion | None = None) -> Outcome:
        reads = self._reader.reads
        return Outcome(
            ending,
            org=reads(SensorName.ORG, self._rest),
            ez=reads(SensorName.EZ, self._rest),
            org_seen=task is not None and task.armed <= task.end_time,
            width=0 if task is None else task.width,
        )

    def _continue(self, t: float, outcome: Outcome | None) -> None:
        """Feed the search what happened; carry out its next actions up to one that takes time."""
        sequence = self._sequence
        while sequence is not None:
            try:
                action = next(sequence) if outcome is None else sequence.send(outcome)
            except StopIteration:
                break
            if isinstance(action, Run):
                self._task = _Motion(self._run_profile(t, action), action.direction, self._rest)
                self._task.step = action
                self._rearm(t)
                return
            if isinstance(action, WaitInp):
                delay = self.scene.inp_delay
                if delay <= INP_TIMEOUT:
                    self._task = _Pause(t + delay, Ending.DONE)
                else:
                    self._task = _Pause(t + INP_TIMEOUT, Ending.TIMEOUT)
                return
            if isinstance(action, PulseClr):
                self._events.append(AxisEvent(t, AxisEventKind.CLEAR))
                outcome = self._outcome(Ending.DONE)
                continue
            if isinstance(action, Finish):
                if action.homed:
                    self._offset = -self._rest
                kind = AxisEventKind.HOMED if action.homed else AxisEventKind.LIMIT
                self._events.append(AxisEvent(t, kind))
                break
        self._sequence = None

    def _run_profile(self, t: float, run: Run) -> MotionProfile:
        settings = self._homing_settings
        if run.until is Until.DISTANCE:
            return _low_run(settings, t, run.pulses)
        if run.speed is Speed.HIGH:
            return plan_jog(settings, start=t).to_high(t)
        return plan_jog(settings, start=t)
