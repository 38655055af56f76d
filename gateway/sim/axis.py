"""One simulated motor of an RC-233: how it moves, what its sensors read, how it finds home.

Lazy and time-driven: a motion is a ``kinematics.MotionProfile`` started at some time; nothing
happens between calls. ``advance(now)`` runs everything due up to ``now`` (motion ends, limit
stops, the next step of a search) and returns the events since the last call. Queries advance
to their ``now`` as well (their events wait for the next ``advance``). Time never goes back.

The axis keeps its mechanical position (scene coordinates, what sensors see) and the position
counter (what command 6 reports) apart: homing and ``R`` change the counter, ``slip`` (lost
pulses) the mechanics. In mode 1 the counter is the encoder's count of the mechanics
(``encoder``, §7-4). Rules around the axis (command errors, modes, EP wrap, flags, EMS state)
belong to the controller. What runs on the axis is a ``course.Motion`` (or a ``course.Pause``);
a search, and what follows a plain motion (the INP wait of mode 2, the QJ adjustment of
mode 1), is driven by ``search.Search`` along a step plan. A plain motion may run under
step-out detection (``stepout``). Choices where the manual is silent: docs/manual-notes.md,
"Simulator axis, sensors and origin searches", "Step-out detection", "Mode 1", "Mode 2".
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from typing import Any

from gateway.protocol.reply_values import SensorBits, SensorLogic
from gateway.protocol.speeds import SpeedSettings
from gateway.sim.counter import PositionCounter
from gateway.sim.course import AxisEvent, AxisEventKind, FollowUp, Leg, Motion, Pause
from gateway.sim.encoder import Encoder
from gateway.sim.homing import Ending, HomingMethod, HomingSetup, Outcome, Until, plan
from gateway.sim.kinematics import MotionProfile, SpeedPoint, plan_jog, plan_move, plan_pulse
from gateway.sim.scene import AxisScene, Direction, SensorName, SensorReader
from gateway.sim.search import Search, inp_wait, readings
from gateway.sim.servo import Servo
from gateway.sim.stepout import Guard

# The controller and the tests take the event types and the search settings from here too.
__all__ = [
    "Axis",
    "AxisBusy",
    "AxisEvent",
    "AxisEventKind",
    "Direction",
    "FollowUp",
    "HomingMethod",
    "HomingSetup",
    "SensorName",
]

#: How many finished legs ``Axis.legs`` keeps.
LEGS_KEPT = 100


class AxisBusy(RuntimeError):
    """A motion was started while the axis is still moving (the controller's command error)."""


class Axis:
    """One motor: motion, sensors and origin searches in simulated time."""

    def __init__(self, scene: AxisScene) -> None:
        self.scene = scene
        self._reader = SensorReader(scene)
        self._rest = scene.start  # mechanical position while nothing runs
        self._task: Motion | Pause | None = None
        self._search: Search | None = None
        self._events: list[AxisEvent] = []
        self._time = -math.inf
        self._legs: deque[Leg] = deque(maxlen=LEGS_KEPT)
        self.step_out_width = 0  # 0QW: ON width of the step-out sensor found by the last 0Q
        self.start_counter = 0  # the counter where the last motion command started (§10 2 II)
        # What 6 reports: 0 at power-on, pulses or (mode 1) encoder counts.
        self.counts = PositionCounter(-scene.start, Encoder(mech_ref=scene.start))
        self.servo = Servo(settle=scene.inp_delay)

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
        if isinstance(self._task, Motion):
            self._task.origin += pulses
            self._task.slipped += pulses
        else:
            self._rest += pulses
        self.counts.lose(pulses)
        self._rearm(now)

    def set_inp(self, now: float, on: bool | None) -> None:
        """The control surface gives INP (True), holds it OFF (False) or lets the driver be."""
        self._advance(now)
        self.servo.hold = on
        task = self._task
        if isinstance(task, Pause) and task.inp_since is not None:
            self._task = inp_wait(task.inp_since, self.servo.inp_at(now))
            self._advance(now)

    def configure(self, now: float, mode: int, pa: int, pb: int) -> None:
        """The mode (§10 E: 1 counts encoder pulses, 2 drives a servo), PA and PB (§10 PA, PB)."""
        self.counts.configure(self.mechanical(now), mode == 1, pa, pb)
        self.servo.active = mode == 2

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
        return self._search is not None

    def mechanical(self, now: float) -> int:
        """Where the axis really is, in scene coordinates."""
        self._advance(now)
        return self._task.position(now) if isinstance(self._task, Motion) else self._rest

    def counter(self, now: float) -> int:
        """The position counter (unbounded; the controller wraps it to 24 bits for EP)."""
        return self.counts.value(self.mechanical(now))

    @property
    def rest(self) -> int:
        """The mechanical position where the axis stands between the tasks of a plan."""
        return self._rest

    def inp(self, now: float) -> bool:
        """The servo driver's INP (mode 2, §10 CI)."""
        self._advance(now)
        return self.servo.inp(now, pulsing=isinstance(self._task, Motion))

    def speed(self, now: float) -> float:
        """Pulse rate [pps], negative when turning CCW."""
        self._advance(now)
        if not isinstance(self._task, Motion):
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
        self.counts.preset(self.mechanical(now), value)

    def move(
        self,
        now: float,
        distance: int,
        settings: SpeedSettings,
        points: tuple[SpeedPoint, ...] = (),
        *,
        guard: Guard | None = None,
        after: FollowUp | None = None,
    ) -> None:
        """1, 3, 4, 5, B, B+(-): ``distance`` pulses (signed, CW positive).

        0 pulses does not turn the motor; ``after`` (mode 1's adjustment) still runs.
        """
        self._idle(now)
        if distance:
            direction = Direction.CW if distance > 0 else Direction.CCW
            profile = plan_move(settings, abs(distance), start=now, points=points)
            self._start(now, Motion(profile, direction, self._rest, guard=guard, after=after))
        elif after is not None:
            self.counts.mark()
            self._search = Search(after.plan(), after.settings, self._reader)
            self._continue(now, None)
            self._advance(now)

    def jog(self, now: float, direction: Direction, settings: SpeedSettings, **extra: Any) -> None:
        """7 / 8: turn at Low speed until S, SS or the limit (§10 7, 8)."""
        self._idle(now)
        self._start(now, Motion(plan_jog(settings, start=now), direction, self._rest, **extra))

    def step(self, now: float, direction: Direction, settings: SpeedSettings, **extra: Any) -> None:
        """7* / 8*: one pulse (§10 7*, 8*)."""
        self._idle(now)
        self._start(now, Motion(plan_pulse(settings, start=now), direction, self._rest, **extra))

    def stop(self, now: float) -> None:
        """S: pulse output stops at once; a search is abandoned (§10 S, §10 0 注意点).

        Mode 2: CLR pulses when S stops a motor that moves (§10 DS ④).
        """
        self._advance(now)
        if self._task is not None and self.servo.active:
            self._emit(AxisEvent(now, AxisEventKind.CLEAR))
        self._halt(now)

    def _halt(self, now: float) -> None:
        self._search = None
        if isinstance(self._task, Motion):
            self._task.profile = self._task.profile.stop(now)
            self._settle(now)
        self._task = None

    def slow_stop(self, now: float) -> None:
        """SS: down to Low speed, then stop; a search is abandoned (§10 SS).

        Mode 2: CLR pulses when SS finds the motor at Low speed (§10 DS ⑤).
        """
        self._advance(now)
        self._search = None
        task = self._task
        if isinstance(task, Motion):
            if self.servo.active and task.profile.speed(now) <= task.profile.settings.fl + 1e-9:
                self._emit(AxisEvent(now, AxisEventKind.CLEAR))
            task.step, task.halting, task.after = None, False, None
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
        start = readings(self._reader, self._rest)
        if method is HomingMethod.STEP_OUT and not start.ez:
            raise ValueError("0Q needs the step-out sensor ON at the start (§10 0Q)")
        self._search = Search(plan(method, setup, start), settings, self._reader)
        self._continue(now, None)
        self._advance(now)

    def emergency(self, now: float) -> None:
        """EMS turned ON: everything stops at once; an EMERGENCY event in any case.

        Mode 2: CLR pulses when EMS stops a plain motion (§10 DS ②, searches excepted).
        """
        self._advance(now)
        if self.servo.active and isinstance(self._task, Motion) and self._search is None:
            self._emit(AxisEvent(now, AxisEventKind.CLEAR))
        self._halt(now)
        self._emit(AxisEvent(now, AxisEventKind.EMERGENCY))

    # --- machinery -----------------------------------------------------------------------

    def _idle(self, now: float) -> None:
        """Refuse a new motion while one runs; note where the new one starts (§10 2 注意点)."""
        self._advance(now)
        if self._task is not None:
            raise AxisBusy("the axis is moving")
        self.start_counter = self.counts.value(self._rest)

    def _edit(self, now: float, change: Callable[[MotionProfile], MotionProfile]) -> None:
        """Apply a speed command to a plain motion (searches keep their course)."""
        self._advance(now)
        task = self._task
        if isinstance(task, Motion) and task.step is None:
            task.profile = change(task.profile)
            self._rearm(now)

    def _start(self, now: float, motion: Motion) -> None:
        motion.counter_origin = self.counts.pulses(self._rest)  # the dog's reference
        self.counts.mark()
        self._task = motion
        self._rearm(now)
        self._advance(now)

    def _emit(self, event: AxisEvent) -> None:
        if event.kind is AxisEventKind.CLEAR:
            self.servo.pulse_clr(event.time)
        self._events.append(event)

    def _advance(self, now: float) -> None:
        if now < self._time:
            raise ValueError(f"time went back from {self._time} to {now}")
        while self._task is not None and self._task.end_time <= now:
            self._finish(self._task)
        self._time = now

    def _rearm(self, t: float) -> None:
        """Work out when the running motion ends early: its limit or its step's condition."""
        if isinstance(self._task, Motion):
            self._task.rearm(self._reader, t)

    def _finish(self, task: Motion | Pause) -> None:
        """The running task's time is up: settle it and go on with the search, if any."""
        t = task.end_time
        if isinstance(task, Pause):
            self._task = None
            self._continue(t, readings(self._reader, self._rest, task.ending))
            return
        ending = task.expire(self._reader)
        if ending is None:
            return
        self._settle(t)
        self._task = None
        if task.step is not None and task.step.until is Until.EZ_WIDTH:
            self.step_out_width = task.width  # 0QW (§10 0Q form IV)
        if task.step is None:
            self._finish_plain(t, task, ending)
            return
        self._continue(t, readings(self._reader, self._rest, ending, task))

    def _finish_plain(self, t: float, task: Motion, ending: Ending) -> None:
        """A move, jog or pulse is over: its limit or step-out stop, else what follows it."""
        kind = {Ending.LIMIT: AxisEventKind.LIMIT, Ending.STEP_OUT: AxisEventKind.STEP_OUT}
        if ending in kind:
            if self.servo.active:  # §10 DS ② (limit), ⑥ (step-out)
                self._emit(AxisEvent(t, AxisEventKind.CLEAR))
            self._emit(AxisEvent(t, kind[ending]))
        elif task.after is not None:
            self._search = Search(task.after.plan(), task.after.settings, self._reader)
            self._continue(t, None)

    def _settle(self, t: float) -> None:
        task = self._task
        assert isinstance(task, Motion)
        self._rest = task.position(t)
        self.servo.pulses_end = t
        self._legs.append(Leg(task.profile.start, t, task.origin, self._rest))

    def _continue(self, t: float, outcome: Outcome | None) -> None:
        """Feed the search what happened; carry out its next actions up to one that takes time."""
        if self._search is None:
            return
        step = self._search.proceed(t, outcome, self._rest, self.servo.inp_at)
        for event in step.events:
            self._emit(event)
        if step.task is not None:
            self._task = step.task
            self._rearm(t)
            return
        if step.homed:  # §10 0X ⑤: the position and the encoder value are cleared
            self.counts.zero(self._rest)
        self._search = None
