"""The line while an axis is watched: spent on it, with the idle controllers still honest.

While a moving axis's position is read back to back, the slow jobs of every controller come
three times further apart (``watched_slow_factor``), and the idle controllers' status reads
stay 1 s apart unless the site spaces them (``watched_idle_period``, here 2 s as a site may set
it); never so far that an axis turns stale (3 s, ``StateCache.stale_after``), an EMS on a
controller that stands is seen within that period, and a controller that goes silent meanwhile
is still reported offline within ``watched_idle_period`` + ``idle_period`` and the polls'
time-outs. Real time (9600 bps, 1 ms
turnaround): the line's own speed is what is measured, in the simulator's seconds.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from itertools import pairwise

import pytest

from gateway.bus.poller import PollConfig
from gateway.bus.state import Change
from tests.support.poll_rig import (
    ALL_BODIES,
    LOOP,
    SKIPPED,
    MakeRig,
    Rig,
    move,
    poller_rigs,
)

DEFAULTS = PollConfig()
#: an idle controller's status reads while an axis is watched, as a site may space them: 2 s
#: apart, and never as far as the 3 s after which the state cache shows its axes stale
SPACED = 2.0
#: device seconds a poll may start late on the line (it waits behind a position read) and
#: this host may add (the real-time tests run beside other work)
LATE = 0.25


@pytest.fixture
async def rig() -> AsyncIterator[MakeRig]:
    async with poller_rigs(1.0) as make:
        yield make


def status_times(r: Rig, body: str, start: float, end: float) -> list[float]:
    """When ``body``'s status was asked for (``""``) in [start, end), simulated seconds."""
    return [f.time for f in r.frames(f"${body}\r".encode(), since=start) if f.time < end]


async def test_a_watched_axis_takes_the_line_from_the_idle_controllers(
    rig: Callable[..., Rig],
) -> None:
    r = await rig("123", watched_idle_period=SPACED)
    await r.identified("123")
    # 40,000 pulses at the default 5,000 pps (OH 5000, §16): about 8 simulated seconds.
    await move(r, "1", 1, 40000)
    await r.until(lambda: r.state.controller(LOOP, "1").selection_confirmed)
    start = r.sim.now() + SPACED  # the idle reads scheduled before the move have run
    end = start + 5.0
    await r.sim_time(end)
    positions = [*r.answered(b"$16\r", start, end), *r.answered(b"$161\r", start, end)]
    frames = r.frames_in(start, end)
    idle = [f for f in frames if f.data[1:2] in (b"2", b"3")]
    # The watched axis has the line: its position read back to back, its status at 5 Hz
    # and more, evenly (the end of the move, limits and EMS seen in time).
    watched = status_times(r, "1", start, end)
    assert len(watched) >= 5 * 5, len(watched)
    # One period missed at most by a busy host (0.38 s beside two CPU hogs), never two.
    assert max(b - a for a, b in pairwise(watched)) < SKIPPED + 0.1, watched
    # (Higher on a quiet host; the host's own delays, at real time, lower it: 0.83 beside two
    # CPU hogs. The idle reads' spacing below is what tells the plan apart.)
    assert len(positions) >= 0.8 * len(frames), (len(positions), len(frames))
    # The idle controllers' status 2 s apart (1 s before), never further than that: their
    # axes stay fresh. All their polls together: some 0.8 frames a second each, against 1.9.
    for body in "23":
        reads = status_times(r, body, start - SPACED, end)
        gaps = [b - a for a, b in pairwise(reads)]
        assert gaps and min(gaps) > SPACED - LATE and max(gaps) < SPACED + LATE, (body, gaps)
    assert len(idle) <= 2 * 1.2 * 5.0, [f.data for f in idle]
    # The move seen to its end; then the idle controllers are back at their own period.
    await r.until(lambda: not r.state.axis(LOOP, "1", 1).moving, 15.0)
    ended = r.sim.now() + SPACED
    await r.sim_time(ended + 3.0)
    for body in "23":
        gaps = [b - a for a, b in pairwise(status_times(r, body, ended, ended + 3.0))]
        assert gaps and max(gaps) < DEFAULTS.idle_period + LATE, (body, gaps)
    assert r.state.axis(LOOP, "1", 1).position == 40000
    assert not any(r.state.controller(LOOP, b).latched for b in "123")


async def test_idle_controllers_stay_fresh_and_a_silent_one_goes_offline_in_time(
    rig: Callable[..., Rig],
) -> None:
    r = await rig("123", watched_idle_period=SPACED)
    await r.identified("123")
    stale: list[Change] = []
    r.state.changes.subscribe(
        lambda c: stale.append(c) if c.motor is not None and c.values.get("stale") else None
    )
    await move(r, "1", 1, 60000)  # about 12 simulated seconds
    await r.until(lambda: r.state.controller(LOOP, "1").selection_confirmed)
    # Well into the spaced plan: body 2 is switched off.
    await r.sim_time(r.sim.now() + SPACED + 0.5)
    assert r.state.axis(LOOP, "1", 1).moving
    off = r.sim.now()
    r.controls.power("2", False)
    await r.until(lambda: r.state.controller(LOOP, "2").online is False, 10.0)
    # Offline within one spaced period, one idle period (the poll after a miss is not
    # spaced) and the two polls' time-outs; 2 s + 1 s by default.
    bound = SPACED + DEFAULTS.idle_period + LATE
    assert r.sim.now() - off < bound, (r.sim.now() - off, bound)
    assert r.state.axis(LOOP, "1", 1).moving  # still watched all along
    # An EMS on a controller that stands is seen within one spaced period (§10 "" bit 2).
    pressed = r.sim.now()
    r.controls.ems("3", True)
    await r.until(lambda: r.state.axis(LOOP, "3", 1).emergency, 10.0)
    assert r.sim.now() - pressed < SPACED + LATE, r.sim.now() - pressed
    assert r.state.axis(LOOP, "1", 1).moving
    # No axis of a controller that answers turned stale because its reads were spaced.
    await r.until(lambda: not r.state.axis(LOOP, "1", 1).moving, 15.0)
    assert [(c.body, c.motor) for c in stale if c.body != "2"] == []
    assert r.state.axis(LOOP, "2", 1).stale  # the silent one's is, as it should be


async def test_among_15_controllers_the_watched_axis_gets_most_of_the_line(
    rig: Callable[..., Rig],
) -> None:
    r = await rig(ALL_BODIES, watched_idle_period=SPACED)
    await r.identified(ALL_BODIES)
    await move(r, "7", 1, 40000)  # about 8 simulated seconds
    await r.until(lambda: r.state.controller(LOOP, "7").selection_confirmed)
    start = r.sim.now() + SPACED  # the idle reads scheduled before the move have run
    end = start + 4.0
    await r.sim_time(end)
    positions = [*r.answered(b"$76\r", start, end), *r.answered(b"$761\r", start, end)]
    frames = r.frames_in(start, end)
    idle = [f for f in frames if f.data[1:2] != b"7"]
    # 14 idle controllers read every second, with their slow jobs, took some 26 frames a
    # second of the line's 55: half of it. Spaced, some 11, and the watched axis has the rest
    # (in the simulator's seconds: a host busy with other work slows both alike).
    assert len(idle) <= 4.0 * 16, len(idle)
    assert len(positions) >= 0.6 * len(frames), (len(positions), len(frames))
    # Each idle controller still read at least every 2 s: none turns stale, none is missed.
    for body in ALL_BODIES.replace("7", ""):
        reads = status_times(r, body, start - SPACED, end)
        gaps = [b - a for a, b in pairwise(reads)]
        assert gaps and max(gaps) < SPACED + LATE, (body, gaps)
    assert not any(r.state.axis(LOOP, b, m).stale for b in ALL_BODIES for m in (1, 2))


async def test_by_default_an_idle_controller_is_read_every_second_while_an_axis_is_watched(
    rig: Callable[..., Rig],
) -> None:
    r = await rig("123")
    await r.identified("123")
    await move(r, "1", 1, 60000)  # about 12 simulated seconds
    await r.until(lambda: r.state.controller(LOOP, "1").selection_confirmed)
    start = r.sim.now() + DEFAULTS.idle_period
    end = start + 10.0
    await r.sim_time(end)
    assert r.state.axis(LOOP, "1", 1).moving
    # An EMS or a program's motion on a controller that stands is seen as soon as when
    # nothing moves: its status stays at ``idle_period``.
    for body in "23":
        gaps = [b - a for a, b in pairwise(status_times(r, body, start, end))]
        assert gaps and max(gaps) < DEFAULTS.idle_period + LATE, (body, gaps)
    # The slow jobs are spaced: an idle controller's sensors (``CLM1``, every 5 s when
    # nothing is watched: twice at least in these 10 s) at most once, 15 s apart.
    for body in "23":
        asked = f"${body}CLM1\r".encode()
        sensors = [f.time for f in r.frames_in(start, end) if f.data == asked]
        assert len(sensors) <= 1, (body, sensors)
