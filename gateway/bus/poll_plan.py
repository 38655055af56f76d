"""The poller's plan: per controller, a set of jobs with due times.

========== ====================================== ===============================================
job        commands                               when
========== ====================================== ===============================================
status     ``""`` (moving, unconfirmed            ``moving_period`` while a motor moves (5.5 Hz),
           selection: ``""`` ``97``)              else ``idle_period``; at once after a move
                                                  starts or a stop was sent, and when the
                                                  moving axis's position repeats
settle     ``6{mt}`` ``CLM{mt}``                  at once when a move has ended (final position)
sensors    ``CLM1`` ``CLM2``; moving: ``CL``      ``sensor_period``
conditions ``90`` ``96`` ``GSS``                  ``condition_period`` (single bits clear nothing,
                                                  §10 9 ②; never ``9`` form I; a program error
                                                  GSS clears is latched by the state)
positions  ``61`` ``62``                          ``position_period`` (both axes)
identify   ``""`` ``V`` ``94`` ``SUM``,           first contact, back online, link up: read from
           ``97`` ``61`` ``62``, ``EE`` ``EL``    the device, never restored from cache
           (``ER`` from ROM 1.19) once stopped
probe      ``""``                                 offline: backoff ``probe_initial`` .. ``_max``
========== ====================================== ===============================================

Not a job: while a motor moves, its position (``6``; ``6{mt}`` until the selection is
confirmed) is read back to back by ``gateway.bus.position_stream``, as often as the line
allows, between these jobs.

What the controller does (moving, answering) is never kept here: the poller reads it from the
state cache, the one home of that knowledge, and hands it to ``schedule``.

While the loop's position stream reads a moving axis (``watching``), the line goes to it: the
slow jobs (sensors, conditions, positions) of every controller come ``watched_slow_factor``
(3) times further apart, and an idle controller's status is read every
``watched_idle_period`` (by default ``idle_period``, 1 s: an EMS or a program's motion on a
controller that stands is seen as soon as when nothing moves; a site may space it). Two bounds
hold a spaced status read: the spaced status read
stays within two thirds of the state cache's ``stale_after`` (host seconds: 3 s, so 2 s), so
an axis never turns stale because the plan spaced its reads; and after a poll nobody answered
the next comes at ``idle_period`` again, so a controller gone silent is offline within
``watched_idle_period`` + ``idle_period`` (and the two polls' time-outs) rather than
2 × ``idle_period`` (docs/performance.md, "The idle controllers while an axis is watched").

Of the jobs that are due the most urgent runs first (the order of ``Job``; an idle status read
ranks with the moving ones), then the one due longest; ``gateway.bus.due_queue`` keeps the due
times in that order, so a pick does not walk every job. Periods are device seconds; due times
are host seconds on the scheduler's clock (its ``time_scale`` maps one to the other for the
simulator). Nothing here reads a clock or talks to the line: ``gateway.bus.poller`` runs the
jobs and reports back.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from enum import IntEnum

from gateway.bus.due_queue import DueQueue, DueTimes
from gateway.protocol.models import Command

__all__ = ["BodyPlan", "Job", "PollConfig", "PollPlan"]

#: the spaced status read of an idle controller at most this share of ``stale_after``: room
#: for the read to wait behind the stream's and for its own exchange before the axis would
#: turn stale
STALE_SHARE = 2 / 3


class Job(IntEnum):
    """A kind of poll; the order is the urgency among jobs that are due."""

    STATUS_MOVING = 0
    SETTLE = 1
    IDENTIFY = 2
    PROBE = 3
    STATUS = 4
    SENSORS = 5
    CONDITIONS = 6
    POSITIONS = 7


def rank(job: Job) -> int:
    """The urgency of a due job: an idle controller's status read ranks with the moving ones'
    (oldest first): moving polls come due faster than a busy line serves them, and an EMS or
    limit on an idle controller must be seen within its period too."""
    return Job.STATUS_MOVING if job is Job.STATUS else job


@dataclass(frozen=True)
class PollConfig:
    """The poll plan's periods, in device seconds."""

    #: the status of a moving controller (the end of the move, limits, EMS): 5 Hz and more,
    #: with room for a read that waits behind another (the position is read back to back)
    moving_period: float = 0.18
    idle_period: float = 1.0
    sensor_period: float = 5.0
    condition_period: float = 10.0
    position_period: float = 10.0
    probe_initial: float = 0.5
    probe_max: float = 30.0
    #: polls in a row without any answer before a controller is marked offline
    offline_after: int = 2
    #: an idle controller's status while the loop's position stream reads a moving axis (never
    #: below ``idle_period``, never above two thirds of the state cache's ``stale_after``);
    #: not spaced by default: that read is where an EMS or a program's motion shows
    watched_idle_period: float = 1.0
    #: sensors, conditions and positions this many times further apart while an axis is
    #: watched (never closer than without)
    watched_slow_factor: float = 3.0


@dataclass
class BodyPlan:
    """The poller's plan for one controller."""

    body: str
    times: DueTimes[Job]
    misses: int = 0  # polls in a row nobody answered
    probe_delay: float = 0.0
    ran_due: float = 0.0  # the due time of the job running (or run last)
    deferred: list[Command] = field(default_factory=list)  # reads refused while moving, to do

    @property
    def due(self) -> Mapping[Job, float]:
        """Its jobs and their due times, host seconds (set through ``times``)."""
        return self.times.view


class PollPlan:
    """The jobs of every controller of one loop: which is due, and when each runs again."""

    def __init__(
        self,
        bodies: Iterable[str],
        config: PollConfig,
        time_scale: float,
        *,
        stale_after: float = float("inf"),
    ) -> None:
        self.config = config
        self.time_scale = time_scale
        #: host seconds without a reply after which the state cache shows an axis stale
        self.stale_after = stale_after
        self._queue: DueQueue[Job] = DueQueue(rank)
        self.bodies = {b: BodyPlan(b, self._queue.add(b)) for b in bodies}

    def host(self, device_seconds: float) -> float:
        """``device_seconds`` in host seconds."""
        return device_seconds / self.time_scale

    def restart(self) -> None:
        """Read every controller again from the device (start, link up)."""
        for plan in self.bodies.values():
            plan.times.replace({Job.IDENTIFY: 0.0})
            plan.misses, plan.deferred = 0, []

    def poll_now(self, body: str, online: bool | None) -> bool:
        """Make ``body``'s status read due before anything else; False if it is not polled
        (unknown, or ``online`` False: offline, probed)."""
        plan = self.bodies.get(body)
        if plan is not None and online is not False:
            plan.times.drop(Job.STATUS)
            plan.times.set(Job.STATUS_MOVING, -1.0)  # before anything else that is due
            return True
        return False

    def pick(self, now: float) -> tuple[BodyPlan, Job] | float:
        """The most urgent due job, or the host time the next one is due."""
        picked = self._queue.pick(now)
        if isinstance(picked, float):
            return picked
        return self.bodies[picked[0]], picked[1]

    def next_due(self, due: float, period: float, now: float) -> float:
        """One period after the last due time, so a poll that started late (the line was
        busy) does not slow the rate; never more than a period in the past (no bursts)."""
        return self._next_due_host(due, self.host(period), now)

    @staticmethod
    def _next_due_host(due: float, step: float, now: float) -> float:
        if due < 0:  # a forced poll: the period starts now
            return now + step
        return due + step if due + step >= now - step else now

    def idle_step(self, plan: BodyPlan, watching: bool) -> float:
        """Host seconds to an idle controller's next status read."""
        c = self.config
        step = self.host(c.idle_period)
        if not watching or plan.misses:  # a poll went unanswered: offline in time
            return step
        spaced = min(self.host(c.watched_idle_period), STALE_SHARE * self.stale_after)
        return max(step, spaced)

    def schedule(
        self,
        plan: BodyPlan,
        job: Job,
        now: float,
        *,
        online: bool | None,
        moving: bool,
        identified: bool = False,
        watching: bool = False,
    ) -> None:
        """Set the next due time of ``job`` (and start the periodic jobs of a new contact).

        ``online`` and ``moving``: the controller as the state cache knows it now;
        ``identified``: an identify job was answered; ``watching``: the loop's position
        stream reads a moving axis (the idle polls are spaced).
        """
        c = self.config
        times = plan.times
        if online is False:
            if job is Job.PROBE:
                plan.probe_delay = min(c.probe_max, max(c.probe_initial, plan.probe_delay * 2))
                times.set(Job.PROBE, now + self.host(plan.probe_delay))
            return
        if job is Job.IDENTIFY:
            if identified:  # start the periodic jobs
                for periodic in (Job.STATUS, Job.SENSORS, Job.CONDITIONS):
                    times.set(periodic, now)
                times.set(Job.POSITIONS, now + self.host(c.position_period))
            else:
                times.set(Job.IDENTIFY, now + self.host(c.idle_period))
            return
        if job in (Job.STATUS, Job.STATUS_MOVING, Job.PROBE):
            times.drop(Job.STATUS)
            times.drop(Job.STATUS_MOVING)
            nxt = Job.STATUS_MOVING if moving else Job.STATUS
            step = self.host(c.moving_period) if moving else self.idle_step(plan, watching)
            # The rate carries on only within one kind; a move starting or ending restarts it.
            due = plan.ran_due if nxt is job else -1.0
            times.set(nxt, self._next_due_host(due, step, now))
            return
        period = _SLOW_PERIODS.get(job)
        if period is not None:
            factor = max(1.0, c.watched_slow_factor) if watching else 1.0
            step = self.host(period(c)) * factor
            times.set(job, self._next_due_host(plan.ran_due, step, now))


#: the slow jobs and their periods
_SLOW_PERIODS: dict[Job, Callable[[PollConfig], float]] = {
    Job.SENSORS: lambda c: c.sensor_period,
    Job.CONDITIONS: lambda c: c.condition_period,
    Job.POSITIONS: lambda c: c.position_period,
}
