"""A step plan under way on one axis (an origin search, or what follows a plain motion):
it feeds the plan and turns its steps into tasks.

``homing.plan`` (or a ``course.FollowUp``: the INP wait of mode 2, the QJ adjustment of mode 1)
says what comes next; ``Search.proceed`` turns a ``Run`` into a ``Motion`` at the plan's speeds
(a counted run at Low speed without ramp, §7-1; High speed ramps up from fL, §10 0A, 0H), a
``WaitInp`` into a ``Pause`` until INP or the 3 s timeout (§10 0X 注意), a ``Wait`` into a
``Pause`` (§10 QJ ①), a ``PulseClr`` (mode 2, §10 0X, §10 DS) and the ``Finish`` into events.
A plan that just ends leaves no event. The ``Axis`` carries the tasks out and reports back
what happened (``readings``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from gateway.protocol.speeds import SpeedSettings
from gateway.sim.course import AxisEvent, AxisEventKind, Motion, Pause, Task, low_run
from gateway.sim.homing import (
    INP_TIMEOUT,
    Ending,
    Outcome,
    PulseClr,
    Run,
    Sequence,
    Speed,
    Until,
    Wait,
    WaitInp,
)
from gateway.sim.kinematics import MotionProfile, plan_jog
from gateway.sim.scene import SensorName, SensorReader

__all__ = ["Next", "Search", "inp_wait", "readings"]


def inp_wait(since: float, inp: float) -> Pause:
    """Waiting from ``since`` for INP, which comes at ``inp``: at most 3 s (§10 0X 注意)."""
    if inp <= since + INP_TIMEOUT:
        return Pause(max(inp, since), Ending.DONE, inp_since=since)
    return Pause(since + INP_TIMEOUT, Ending.TIMEOUT, inp_since=since)


def readings(
    reader: SensorReader, here: int, ending: Ending = Ending.DONE, motion: Motion | None = None
) -> Outcome:
    """What the axis reports after a step: how it ended, what ORG / EZ read at ``here``.

    ``motion`` is the run that ended, if any: whether it had confirmed ORG, the width it measured.
    """
    return Outcome(
        ending,
        org=reader.reads(SensorName.ORG, here),
        ez=reader.reads(SensorName.EZ, here),
        org_seen=motion is not None and motion.armed <= motion.end_time,
        width=0 if motion is None else motion.width,
    )


@dataclass(frozen=True)
class Next:
    """What the search asks of the axis: a task to run, else it is over (``homed`` or not)."""

    task: Task | None = None
    events: list[AxisEvent] = field(default_factory=list)  # CLEAR ..., HOMED or LIMIT at the end
    homed: bool = False  # the origin is here: the counter becomes 0


class Search:
    """The step plan of one search and the speeds it runs at."""

    def __init__(self, sequence: Sequence, settings: SpeedSettings, reader: SensorReader) -> None:
        self._sequence = sequence
        self._settings = settings
        self._reader = reader

    def proceed(
        self, t: float, outcome: Outcome | None, here: int, inp_at: Callable[[float], float]
    ) -> Next:
        """Feed the plan ``outcome`` (None: start it); go on up to an action that takes time.

        ``here`` is the axis's mechanical position, ``inp_at(t)`` when the driver's INP is ON
        from t on (``inf``: held OFF).
        """
        events: list[AxisEvent] = []
        while True:
            try:
                action = next(self._sequence) if outcome is None else self._sequence.send(outcome)
            except StopIteration:
                return Next(events=events)
            if isinstance(action, Run):
                motion = Motion(self._profile(t, action), action.direction, here, step=action)
                return Next(motion, events)
            if isinstance(action, WaitInp):
                return Next(inp_wait(t, inp_at(t)), events)
            if isinstance(action, Wait):
                return Next(Pause(t + action.seconds, Ending.DONE), events)
            if isinstance(action, PulseClr):
                events.append(AxisEvent(t, AxisEventKind.CLEAR))
                outcome = readings(self._reader, here)
                continue
            kind = AxisEventKind.HOMED if action.homed else AxisEventKind.LIMIT
            return Next(events=[*events, AxisEvent(t, kind)], homed=action.homed)

    def _profile(self, t: float, run: Run) -> MotionProfile:
        settings = self._settings
        if run.until is Until.DISTANCE:
            return low_run(settings, t, run.pulses)
        if run.speed is Speed.HIGH:
            return plan_jog(settings, start=t).to_high(t)
        return plan_jog(settings, start=t)
