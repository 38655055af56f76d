"""Real-time motion at time scale 1, as a host on the line sees it.

A move is started over the in-process line at 9600 bps and ``""`` is polled until bit 0 is 0,
as the manual's sample programs do (§13-2 CHECK). The line log gives the simulated time each
frame was heard, so the end of the move is bracketed by the last poll that saw it moving and
the first that saw it stopped; at scale 1 that clock is the real one, which the test checks
against ``time.monotonic`` too. Expected durations are worked out by hand from chapter 7 with
the default speed data (OH 5000, OL 500, OS 300, OX 300: fH 5000 pps, fL 500 pps,
α = 1,474,560,000 / (300 × 300) = 16,384 pps/s, tacc = 4500 / 16,384 = 0.27466 s):

- 2,000 pulses, trapezoid: ramps cover 2 × (500 + 5000) / 2 × 0.27466 = 1510.6 pulses, so
  489.4 pulses cruise at 5000 pps (0.09788 s): 2 × 0.27466 + 0.09788 = 0.6472 s.
- 1,000 pulses, shorter than the two ramps: the move turns at fH' where
  (fH'² − fL²) / α = 1000, fH' = 4077.2 pps; 2 × (fH' − fL) / α = 0.4368 s (§7-3).
- 4,000 pulses with OC 50 (S-curve, §7-1): tacc = 4500 / (24,576 × 150) × 300 = 0.36621 s,
  ramps cover 2 × 2750 × 0.36621 = 2014.2 pulses, cruise 1985.8 / 5000 = 0.39716 s:
  2 × 0.36621 + 0.39716 = 1.1296 s.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable

import pytest

from gateway.sim.clock import RecordKind
from tests.support.sim_wire import Wire

STATUS = re.compile(rb">\$1([0-9A-F])\r")


async def _timed_move(wire: Wire, setup: list[bytes]) -> tuple[float, float]:
    """Run ``setup`` (the last frame starts the move): its duration on the simulated clock
    (middle of the bracket the polls give) and as the host measured it in real time."""
    for frame in setup:
        assert await wire.exchange(frame) == b">"
    heard = [r for r in wire.records(RecordKind.HEARD) if r.ref > 0]
    start = heard[-1].time  # the controller acts on a frame when its CR has arrived
    # the host's time of that CR (scale 1), not of this line: a busy host gets here late
    real_start = time.monotonic() - (wire.loop.now() - start)
    last_moving = start
    while True:
        mark = wire.loop.log.next_seq
        reply = await wire.exchange(b"$1\r")
        poll = next(r for r in wire.loop.log.since(mark) if r.kind is RecordKind.HEARD)
        found = STATUS.fullmatch(reply)
        assert found, reply
        if not int(found.group(1), 16) & 1:
            real = time.monotonic() - real_start
            return (last_moving + poll.time) / 2 - start, real
        last_moving = poll.time


@pytest.mark.parametrize(
    ("setup", "expected"),
    [
        ([b"$122000\r", b"$13\r"], 0.6472),
        ([b"$121000\r", b"$13\r"], 0.4368),
        ([b"$1OC50\r", b"$124000\r", b"$13\r"], 1.1296),
    ],
    ids=["2000-pulses", "1000-pulses-short", "4000-pulses-OC50"],
)
async def test_a_move_ends_when_chapter_7_says(
    make_wire: Callable[..., Wire], setup: list[bytes], expected: float
) -> None:
    wire = make_wire("1", scale=1.0)
    duration, real = await _timed_move(wire, setup)
    assert duration == pytest.approx(expected, rel=0.02)
    # Scale 1 is real time: the host saw the end no earlier than the move could end, and
    # no later than a few polls (about 10 ms each at 9600 bps) plus scheduling slack.
    assert expected * 0.98 <= real <= expected * 1.02 + 0.1
