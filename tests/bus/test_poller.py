"""The poller against the real scheduler on the in-process simulator.

What is checked is what a user of the gateway would notice: the frames on the simulated line
(its log, in simulated seconds), the state the cache shows, and the device's own flags read
back through the scheduler. Waiting is always on a condition (state changes, line records),
never on a sleep.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from itertools import pairwise

import pytest

from gateway.bus.requests import Priority
from gateway.bus.state import Change, ErrorKind
from gateway.protocol.command_text import parse
from gateway.protocol.reply_values import ProgramState, StatusFlags
from gateway.sim.clock import RecordKind
from tests.support.poll_rig import (
    ALL_BODIES,
    LOOP,
    SKIPPED,
    MakeRig,
    Rig,
    move,
    poller_rigs,
)


@pytest.fixture
async def rig() -> AsyncIterator[MakeRig]:
    async with poller_rigs(5.0) as make:
        yield make


async def test_moving_axis_gets_15_position_reads_a_second_among_15_controllers(
    rig: Callable[..., Rig],
) -> None:
    r = await rig(ALL_BODIES, scale=1.0)
    # Every controller identified from the device first (V read on the line).
    await r.identified(ALL_BODIES)
    assert all(r.state.controller(LOOP, b).version for b in ALL_BODIES)
    # 20,000 pulses at the default 5,000 pps (OH 5000, §16): about 4 simulated seconds.
    await move(r, "7", 1, 20000)
    await r.until(lambda: r.state.axis(LOOP, "7", 1).moving)
    start = r.sim.now()
    await r.sim_time(start + 2.0)
    # Position reads: 6 of the selected (moving) motor, or 61 until the selection is read back.
    end = start + 2.0
    replies = [*r.answered(b"$76\r", start, end), *r.answered(b"$761\r", start, end)]
    assert len(replies) >= 2 * 15, f"{len(replies)} position reads in 2 simulated seconds"
    # The idle controllers are still watched: each had its status read in that window.
    for body in ALL_BODIES.replace("7", ""):
        assert r.frames(f"${body}\r".encode(), since=start), body
    # The position the cache shows follows the move.
    await r.until(lambda: not r.state.axis(LOOP, "7", 1).moving)
    await r.until(lambda: r.state.axis(LOOP, "7", 1).position == 20000)
    # Thousands of polls, and not one of them refused by a controller (a command error).
    assert not any(r.state.controller(LOOP, b).latched for b in ALL_BODIES)


async def test_an_error_the_poller_cleared_is_reported_until_acknowledged(
    rig: Callable[..., Rig],
) -> None:
    r = await rig("12", scale=5.0)
    seen: list[Change] = []
    r.state.changes.subscribe(seen.append)  # a subscriber (a dashboard, say)
    await r.until(lambda: r.state.controller(LOOP, "1").version is not None)
    await move(r, "1", 1, 20000)
    await r.until(lambda: r.state.axis(LOOP, "1", 1).moving)
    # The CW limit sensor turns ON while the motor runs CW: the controller stops with a
    # limit error (§10 "" bit 1).
    r.controls.sensor("1", 1, "cw_limit", True)
    await r.until(lambda: r.state.axis(LOOP, "1", 1).limit_error)
    # The poll after the stop reads the sensors of the motor that moved: CWLS ON (§10 CL).
    await r.until(lambda: getattr(r.state.axis(LOOP, "1", 1).sensors, "cw_limit", False))
    latch = r.state.controller(LOOP, "1").latched[ErrorKind.LIMIT]
    assert latch.source == '""' and latch.axes == {1}
    # The poller's "" cleared it on the device: a read now shows no error ...
    result = await r.scheduler.submit("1", [parse("")], priority=Priority.OPERATOR)
    assert isinstance(result.value, StatusFlags) and not result.value.limit_error
    # ... and polls go on, yet the gateway still reports it, to every subscriber.
    polls = len(r.frames(b"$1\r"))
    await r.until(lambda: len(r.frames(b"$1\r")) >= polls + 3)
    assert r.state.axis(LOOP, "1", 1).limit_error
    assert any(c.body == "1" and c.motor == 1 and c.values.get("limit_error") for c in seen)
    # Acknowledged: gone, and it does not come back with the next polls.
    assert r.state.acknowledge(LOOP, "1", r.scheduler.clock(), motor=1) == [ErrorKind.LIMIT]
    polls = len(r.frames(b"$1\r"))
    await r.until(lambda: len(r.frames(b"$1\r")) >= polls + 3)
    assert not r.state.axis(LOOP, "1", 1).limit_error


async def test_a_controller_switched_off_goes_offline_and_comes_back_identified(
    rig: Callable[..., Rig],
) -> None:
    # At scale 2 an idle poll every 0.2 s is one every 100 ms of real time: room for a host
    # that is busy with other work (at scale 5 it polled 19 times of 20 beside a CPU hog).
    r = await rig("12", scale=2.0, idle_period=0.2, probe_initial=0.4, probe_max=2.0)
    await r.identified("12")
    r.controls.power("2", False)
    await r.until(lambda: r.state.controller(LOOP, "2").online is False)
    assert r.state.axis(LOOP, "2", 1).stale and r.state.controller(LOOP, "1").online
    # Offline it is probed with backoff (0.4, 0.8, 1.6, 2.0 s), not polled every 0.2 s.
    offline = r.sim.now()
    await r.sim_time(offline + 5.0)
    r.assert_probed_with_backoff("2", offline)
    # Body 1 was polled at its idle rate all along.
    assert len(r.frames(b"$1\r", since=offline)) >= 5.0 / 0.2 * 0.8
    on = r.sim.now()
    r.controls.power("2", True)
    await r.until(lambda: r.state.controller(LOOP, "2").online is True)
    # Back online: version, mode and framing read again from the device, after the power-on.
    for frame in (b"$2V\r", b"$294\r", b"$2SUM\r", b"$2EE\r", b"$2EL\r", b"$2ER\r"):
        await r.until(lambda f=frame: bool(r.frames(f, since=on)))  # type: ignore[misc]


async def test_link_up_reads_every_controller_again(rig: Callable[..., Rig]) -> None:
    r = await rig("12", scale=5.0)
    await r.until(lambda: all(r.state.controller(LOOP, b).version for b in "12"))
    mark = r.sim.now()
    r.ports[-1].close()  # the line goes away; the scheduler reopens it (a new port)
    await r.until(lambda: len(r.ports) >= 2 and bool(r.frames(b"$1V\r", since=mark)))
    await r.until(lambda: bool(r.frames(b"$2V\r", since=mark)))
    assert r.state.loop(LOOP).up
    # The slower polls carry on as well: the program state (GSS '0': no program running).
    await r.until(lambda: r.state.controller(LOOP, "2").program is ProgramState.ENDED)


async def test_a_move_started_by_a_client_is_polled_at_once(rig: Callable[..., Rig]) -> None:
    # Idle polls once a (simulated) minute: only the forced poll can see the move start.
    r = await rig("1", scale=5.0, idle_period=60.0)
    await r.identified("1")
    await move(r, "1", 2, 20000)
    # From the move's frame on the line: on a busy host the poller may read the status before
    # this task runs again.
    started = r.frames(b"$132\r")[-1].time
    # The '>' makes the axis moving at once; the forced status read confirms it.
    assert r.state.axis(LOOP, "1", 2).moving

    def status_moving() -> bool:
        status = r.state.controller(LOOP, "1").status
        return status is not None and status.moving

    await r.until(status_moving, 5.0)
    status = r.frames(b"$1\r", since=started)
    assert status and status[0].time - started < 0.5  # idle polls are a minute apart
    # No poll was refused for the move (E, EE, EL, ER, CLM are not usable while moving):
    # no command error appears that nobody made.
    await r.until(lambda: not r.state.axis(LOOP, "1", 2).moving, 10.0)
    await r.until(lambda: r.state.controller(LOOP, "1").status is not None)
    assert ErrorKind.COMMAND not in r.state.controller(LOOP, "1").latched


async def test_a_watched_axis_is_read_back_to_back_with_its_status_at_5_hz(
    rig: Callable[..., Rig],
) -> None:
    # Real time: the line's own speed is what is measured (9600 bps, 1 ms turnaround).
    r = await rig("123", scale=1.0)
    await r.identified("123")
    # 20,000 pulses at the default 5,000 pps (OH 5000, §16): about 4 simulated seconds.
    await move(r, "1", 1, 20000)
    await r.until(lambda: r.state.controller(LOOP, "1").selection_confirmed)
    start = r.sim.now()
    await r.sim_time(start + 2.0)
    end = start + 2.0
    positions = [*r.answered(b"$16\r", start, end), *r.answered(b"$161\r", start, end)]
    status = [f.time for f in r.frames(b"$1\r", since=start) if f.time < end]
    frames = r.frames_in(start, end)
    # A position read is 16 characters and a turnaround (some 18 ms: 56 a second on a line
    # with nothing else); the old plan read it every 50 ms (20 a second, half the frames).
    assert len(positions) >= 2 * 28, f"{len(positions)} position reads in 2 simulated seconds"
    assert len(positions) >= 0.65 * len(frames), (len(positions), len(frames))
    # The status at 5 Hz and more, evenly: the end of the move and errors are seen in time.
    gaps = [b - a for a, b in pairwise(status)]
    assert len(status) >= 2 * 5 and max(gaps) < SKIPPED, (len(status), gaps)
    # The idle controllers not at the moving one's period: 2 s apart while an axis is
    # watched (test_watched_line.py: never further, and back to 1 s when the move ends).
    for body in "23":
        idle = [f for f in r.frames(f"${body}\r".encode(), since=start) if f.time < end]
        assert len(idle) <= 2, (body, len(idle))
    # With the selection read back, the position is read without a suffix (a character
    # less); no F was asked for while the motor moved (it would be refused, §10 F).
    assert r.answered(b"$16\r", start, end)
    assert not [f for f in r.sim.log.since(0) if f.kind is RecordKind.HEARD
                and f.data.startswith(b"$1F") and f.time >= start]  # fmt: skip
    # The end of the move is seen, with its final position, and nothing was refused.
    await r.until(lambda: not r.state.axis(LOOP, "1", 1).moving)
    await r.until(lambda: r.state.axis(LOOP, "1", 1).position == 20000)
    assert not r.state.controller(LOOP, "1").latched


async def test_a_limit_error_during_a_watched_move_is_seen(rig: Callable[..., Rig]) -> None:
    r = await rig("12", scale=1.0)
    await r.identified("12")
    await move(r, "1", 1, 20000)
    await r.until(lambda: len(r.frames(b"$16\r")) + len(r.frames(b"$161\r")) >= 5)
    hit = r.sim.now()
    r.controls.sensor("1", 1, "cw_limit", True)
    await r.until(lambda: r.state.axis(LOOP, "1", 1).limit_error)
    # Seen by the status read within its period (5 Hz and more), the move ended with it.
    assert r.sim.now() - hit < 0.5
    await r.until(lambda: not r.state.axis(LOOP, "1", 1).moving)
    stopped = r.sim.now()
    # No position stream is left reading a motor that stands: the line goes back to the plan.
    await r.sim_time(stopped + 1.0)
    assert len(r.frames(b"$16\r", since=stopped + 0.2)) <= 1


async def test_two_watched_axes_share_the_positions_and_keep_their_status_rate(
    rig: Callable[..., Rig],
) -> None:
    r = await rig("123", scale=1.0)
    await r.identified("123")
    await move(r, "1", 1, 20000)
    await move(r, "2", 1, 20000)
    await r.until(lambda: all(r.state.controller(LOOP, b).selection_confirmed for b in "12"))
    start = r.sim.now()
    await r.sim_time(start + 2.0)
    end = start + 2.0
    for body in "12":
        reads = [
            *r.answered(f"${body}6\r".encode(), start, end),
            *r.answered(f"${body}61\r".encode(), start, end),
        ]
        # The line's 55 exchanges a second, less the status reads, in turn between the two.
        assert len(reads) >= 2 * 12, (body, len(reads))
        status = [f.time for f in r.frames(f"${body}\r".encode(), since=start) if f.time < end]
        gaps = [b - a for a, b in pairwise(status)]
        assert len(status) >= 2 * 5 and max(gaps) < SKIPPED, (body, len(status), gaps)
    idle = [f for f in r.frames(b"$3\r", since=start) if f.time < end]
    assert len(idle) <= 2, len(idle)
    await r.until(lambda: not any(r.state.axis(LOOP, b, 1).moving for b in "12"))
    await r.until(lambda: all(r.state.axis(LOOP, b, 1).position == 20000 for b in "12"))
    assert not any(r.state.controller(LOOP, b).latched for b in "123")


async def test_the_end_of_a_watched_move_is_seen_two_position_reads_after_it(
    rig: Callable[..., Rig],
) -> None:
    # A quarter of real time: what is measured is the line's (device seconds), and a host
    # busy with other work shows in device time at a quarter of its length (at half, a
    # clean-clone run beside a soak and other tests still saw 0.087 s).
    r = await rig("12", scale=0.25)
    await r.identified("12")
    for target in (2000, 4000, 6000):  # 2,000 pulses at 5,000 pps: 0.4 s each
        await move(r, "1", 1, target)
        await r.until(lambda: r.state.axis(LOOP, "1", 1).moving)
        await r.until(lambda: not r.state.axis(LOOP, "1", 1).moving)
        # The first reply on the line that showed the final position, and the status
        # reply that showed the motor stopped: the status was read at once, not at its
        # next period (0.18 s).
        final = f">$1{target:08d}\r".encode()
        reached = min(x.time for x in r.sim.log.since(0)
                      if x.kind is RecordKind.REPLY and x.data == final)  # fmt: skip
        status = r.answered(b"$1\r", reached, float("inf"))
        stopped = min(x.time for x in status if x.data == b">$10\r")
        # Within 0.12 s: well before the next period (0.18 s). Beside two CPU hogs the poller's
        # wake came late enough for 0.088 s of position reads, at any time scale.
        assert stopped - reached <= 0.12, (target, stopped - reached)
