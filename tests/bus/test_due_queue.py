"""The poll plan's ordered due times choose exactly what a walk over every job chose.

``walk_pick`` is the plan's former ``pick``, kept here as the reference: every job of every
controller compared on each pick. The plan is driven the way the poller drives it (pick, run
the job, schedule it again; forced status reads, moves ending, controllers going silent and
coming back, the link coming up), with seeded random answers and a clock that only goes
forward, and every pick is compared with the walk over the same due times.
"""

from __future__ import annotations

import random

import pytest

from gateway.bus.poll_plan import BodyPlan, Job, PollConfig, PollPlan


def walk_pick(plan: PollPlan, now: float) -> tuple[str, Job] | float:
    """The most urgent due job by a walk over every job (the plan's former ``pick``)."""
    best: tuple[Job, float, str] | None = None
    picked = Job.STATUS
    earliest = float("inf")
    for body_plan in plan.bodies.values():
        for job, due in body_plan.due.items():
            rank = Job.STATUS_MOVING if job is Job.STATUS else job
            if due <= now and (best is None or (rank, due, body_plan.body) < best):
                best = (rank, due, body_plan.body)
                picked = job
            earliest = min(earliest, due)
    if best is None:
        return earliest
    return best[2], picked


def chosen(picked: tuple[BodyPlan, Job] | float) -> tuple[str, Job] | float:
    return picked if isinstance(picked, float) else (picked[0].body, picked[1])


def drive(seed: int, bodies: str, steps: int) -> int:
    """Run the plan ``steps`` times as the poller would; the picks that chose a job."""
    rng = random.Random(seed)
    config = PollConfig(
        moving_period=rng.choice([0.05, 0.18, 0.3]),
        idle_period=rng.choice([0.2, 1.0, 2.0]),
        probe_initial=0.4,
        probe_max=2.0,
    )
    plan = PollPlan(bodies, config, rng.choice([1.0, 5.0]), stale_after=3.0)
    plan.restart()
    online = dict.fromkeys(bodies, True)
    moving = dict.fromkeys(bodies, False)
    now, jobs_run = 0.0, 0
    for _ in range(steps):
        now += rng.choice([0.0, 0.0, 0.001, 0.017, 0.2, 1.5])
        event = rng.random()
        body = rng.choice(bodies)
        if event < 0.04:  # a move or a stop sent: its status at once
            moving[body] = rng.random() < 0.7
            plan.poll_now(body, online[body])
        elif event < 0.06 and online[body]:  # a move ended: its final position now
            moving[body] = False
            plan.bodies[body].times.set(Job.SETTLE, now)
        elif event < 0.07:  # found silent: probed from now on
            online[body] = False
            plan.bodies[body].times.replace({Job.PROBE: now + plan.host(0.4)})
        elif event < 0.08 and not online[body]:  # heard again: identified first
            online[body] = True
            plan.bodies[body].times.replace({Job.IDENTIFY: now})
        elif event < 0.085:  # the link came up again
            plan.restart()
        expected = walk_pick(plan, now)
        got = chosen(plan.pick(now))
        assert got == expected, (seed, now, got, expected)
        if isinstance(got, float):
            continue
        jobs_run += 1
        body_plan = plan.bodies[got[0]]
        body_plan.ran_due = body_plan.times.take(got[1])
        if rng.random() < 0.03:  # the line went down under the poll: the job again first
            body_plan.times.set(got[1], 0.0)
            continue
        body_plan.misses = 0 if online[got[0]] else body_plan.misses + 1
        plan.schedule(
            body_plan,
            got[1],
            now,
            online=online[got[0]],
            moving=moving[got[0]],
            identified=rng.random() < 0.8,
            watching=any(moving.values()),
        )
    return jobs_run


@pytest.mark.parametrize("seed", range(40))
def test_the_ordered_due_times_pick_what_the_walk_picked(seed: int) -> None:
    bodies = "0123456789ABCDE"[: 1 + seed % 15]
    assert drive(seed, bodies, 3000) > 300  # jobs were run, not only waits compared


def test_a_clock_set_back_is_followed() -> None:
    plan = PollPlan("12", PollConfig(), 1.0)
    plan.restart()
    for body_plan in plan.bodies.values():
        body_plan.times.take(Job.IDENTIFY)
        body_plan.times.set(Job.STATUS, 5.0)
    plan.bodies["2"].times.set(Job.SENSORS, 1.0)
    assert chosen(plan.pick(6.0)) == ("1", Job.STATUS)
    # A test's clock set back to before the status reads: only the sensors are due.
    assert chosen(plan.pick(2.0)) == ("2", Job.SENSORS)
    assert plan.pick(0.5) == 1.0


def test_due_times_set_over_and_over_keep_the_heap_bounded() -> None:
    plan = PollPlan("0123456789ABCDE", PollConfig(), 1.0)
    plan.restart()
    for i in range(20_000):  # forced status reads that never run (each pushes an entry)
        plan.poll_now("0123456789ABCDE"[i % 15], True)
        plan.bodies["0123456789ABCDE"[i % 15]].times.set(Job.POSITIONS, 100.0 + i)
        plan.pick(float(i) * 1e-6)
    assert len(plan._queue._timeline) + len(plan._queue._ready) < 1000
