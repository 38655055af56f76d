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

Of the jobs that are due the most urgent runs first (the order of ``Job``; an idle status read
ranks with the moving ones), then the one due longest. Periods are device seconds; due times
are host seconds on the scheduler's clock (its ``time_scale`` maps one to the other for the
simulator). Nothing here reads a clock or talks to the line: ``gateway.bus.poller`` runs the
jobs and reports back.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from enum import IntEnum

from gateway.protocol.models import Command

__all__ = ["BodyPlan", "Job", "PollConfig", "PollPlan"]


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


@dataclass
class BodyPlan:
    """The poller's plan for one controller."""

    body: str
    due: dict[Job, float] = field(default_factory=dict)
    misses: int = 0  # polls in a row nobody answered
    probe_delay: float = 0.0
    ran_due: float = 0.0  # the due time of the job running (or run last)
    deferred: list[Command] = field(default_factory=list)  # reads refused while moving, to do


class PollPlan:
    """The jobs of every controller of one loop: which is due, and when each runs again."""

    def __init__(self, bodies: Iterable[str], config: PollConfig, time_scale: float) -> None:
        self.config = config
        self.time_scale = time_scale
        self.bodies = {b: BodyPlan(b) for b in bodies}

    def host(self, device_seconds: float) -> float:
        """``device_seconds`` in host seconds."""
        return device_seconds / self.time_scale

    def restart(self) -> None:
        """Read every controller again from the device (start, link up)."""
        for plan in self.bodies.values():
            plan.due = {Job.IDENTIFY: 0.0}
            plan.misses, plan.deferred = 0, []

    def poll_now(self, body: str, online: bool | None) -> bool:
        """Make ``body``'s status read due before anything else; False if it is not polled
        (unknown, or ``online`` False: offline, probed)."""
        plan = self.bodies.get(body)
        if plan is not None and online is not False:
            plan.due.pop(Job.STATUS, None)
            plan.due[Job.STATUS_MOVING] = -1.0  # before anything else that is due
            return True
        return False

    def pick(self, now: float) -> tuple[BodyPlan, Job] | float:
        """The most urgent due job, or the host time the next one is due."""
        best: tuple[Job, float, str] | None = None
        picked = Job.STATUS
        earliest = float("inf")
        for plan in self.bodies.values():
            for job, due in plan.due.items():
                # An idle controller's status read ranks with the moving ones' (oldest
                # first): moving polls come due faster than a busy line serves them, and
                # an EMS or limit on an idle controller must be seen within its period too.
                rank = Job.STATUS_MOVING if job is Job.STATUS else job
                if due <= now and (best is None or (rank, due, plan.body) < best):
                    best = (rank, due, plan.body)
                    picked = job
                if due < earliest:  # not min(): this runs for every job of every poll
                    earliest = due
        if best is None:
            return earliest
        return self.bodies[best[2]], picked

    def next_due(self, due: float, period: float, now: float) -> float:
        """One period after the last due time, so a poll that started late (the line was
        busy) does not slow the rate; never more than a period in the past (no bursts)."""
        step = self.host(period)
        if due < 0:  # a forced poll: the period starts now
            return now + step
        return due + step if due + step >= now - step else now

    def schedule(
        self,
        plan: BodyPlan,
        job: Job,
        now: float,
        *,
        online: bool | None,
        moving: bool,
        identified: bool = False,
    ) -> None:
        """Set the next due time of ``job`` (and start the periodic jobs of a new contact).

        ``online`` and ``moving``: the controller as the state cache knows it now;
        ``identified``: an identify job was answered.
        """
        c = self.config
        if online is False:
            if job is Job.PROBE:
                plan.probe_delay = min(c.probe_max, max(c.probe_initial, plan.probe_delay * 2))
                plan.due[Job.PROBE] = now + self.host(plan.probe_delay)
            return
        if job is Job.IDENTIFY:
            if identified:  # start the periodic jobs
                plan.due.update({Job.STATUS: now, Job.SENSORS: now, Job.CONDITIONS: now})
                plan.due[Job.POSITIONS] = now + self.host(c.position_period)
            else:
                plan.due[Job.IDENTIFY] = now + self.host(c.idle_period)
            return
        periods = {
            Job.SENSORS: c.sensor_period,
            Job.CONDITIONS: c.condition_period,
            Job.POSITIONS: c.position_period,
        }
        if job in (Job.STATUS, Job.STATUS_MOVING, Job.PROBE):
            plan.due.pop(Job.STATUS, None)
            plan.due.pop(Job.STATUS_MOVING, None)
            nxt = Job.STATUS_MOVING if moving else Job.STATUS
            period = c.moving_period if moving else c.idle_period
            # The rate carries on only within one kind; a move starting or ending restarts it.
            due = plan.ran_due if nxt is job else -1.0
            plan.due[nxt] = self.next_due(due, period, now)
        elif job in periods:
            plan.due[job] = self.next_due(plan.ran_due, periods[job], now)
