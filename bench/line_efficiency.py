"""How much of the serial line the loop scheduler uses, and how fast a stop gets through.

The simulated loop runs at the line's real character timing (``--time-scale 1``, the default,
9600 bps, 1 ms controller turnaround); the scheduler's queue is kept full of reads from several
callers over three controllers. The simulator's own line log is the ruler: for every frame the
controllers heard, the wire time of the command, the turnaround and the wire time of the reply
(10 bits a character) count as busy; the figure is busy time over elapsed time in the measured
window (target >= 0.97). Meanwhile a stop is submitted now and then; its latency is the
time from ``submit`` to the moment the controller has heard the whole ``S`` frame, in device
milliseconds (p50 and p99).

``host_gap_ms`` is the scheduler's own share of the idle time, measured on the host: real time
from the last byte of a reply to the next frame written. ``scheduler_efficiency`` is the line
use those gaps alone would leave. The simulator runs with a precise clock here
(``SimClock(precise=True)``): asyncio's own timers wake up to a millisecond late (epoll waits
are rounded up to whole milliseconds), twice per exchange, which alone would cost some 6 % of
the line and hide the scheduler's figure.

    .venv/bin/python bench/line_efficiency.py                 # real time, 10 s
    .venv/bin/python bench/line_efficiency.py --time-scale 20 --seconds 1   # what make test runs

It prints one JSON object. Times are device (simulated) seconds, so figures taken at another
time scale compare, although host latency weighs more there.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import statistics
import time
from collections.abc import Callable
from typing import Any

from gateway.bus.config import LoopConfig
from gateway.bus.requests import Priority
from gateway.bus.scheduler import LoopScheduler
from gateway.protocol.command_text import parse
from gateway.protocol.framing import BAUD_RATES, BITS_PER_CHAR
from gateway.sim.cli import build_loop
from gateway.sim.clock import RecordKind, SimClock
from gateway.sim.serve import SimPort
from gateway.transport.base import Sink, TransportClosed
from gateway.transport.pipe import PipeTransport

BODIES = ["1", "2", "3"]
READS = ["6", "OH", "9{b}", "CL", "2D", "OX"]


class _Timed(PipeTransport):
    """The in-process transport, noting when a reply ended and when the next frame left."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.host_gaps: list[float] = []  # real seconds from a reply's CR to the next write
        self._reply_end: float | None = None

    def _noted(self, data: bytes) -> bytes:
        if data.endswith(b"\r") or data.endswith(b">"):
            self._reply_end = time.perf_counter()
        return data

    async def read(self) -> bytes:
        return self._noted(await super().read())

    def deliver(self, sink: Sink | None) -> bool:
        # The receiver takes each chunk from the connection's callback (no read): note there.
        return super().deliver(None if sink is None else _Noting(sink, self._noted))

    def write(self, data: bytes) -> None:
        if self._reply_end is not None:
            self.host_gaps.append(time.perf_counter() - self._reply_end)
            self._reply_end = None
        super().write(data)


class _Noting(Sink):
    """A receiver's sink, each chunk noted on its way."""

    def __init__(self, sink: Sink, note: Callable[[bytes], bytes]) -> None:
        self._sink, self._note = sink, note

    def received(self, data: bytes) -> None:
        self._sink.received(self._note(data))

    def closed(self, error: TransportClosed) -> None:
        self._sink.closed(error)


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


async def _reader(scheduler: LoopScheduler, body: str, n: int, stop: asyncio.Event) -> None:
    commands = [parse(text.replace("{b}", "4")) for text in READS]
    i = n
    while not stop.is_set():
        await scheduler.submit(body, commands[i % len(commands)], priority=Priority.POLL)
        i += 1


async def measure(seconds: float, scale: float, baud: int, callers: int) -> dict[str, object]:
    """Run the load for ``seconds`` of device time; the figures."""
    clock = SimClock(scale, precise=True)  # real character timing, not asyncio's 1 ms steps
    sim = build_loop(BODIES, clock=clock, baud=baud)
    transport = _Timed(lambda: SimPort(sim), url="pipe://sim", baud=baud)
    scheduler = LoopScheduler(transport, LoopConfig(name="bench", time_scale=scale))
    await scheduler.start()
    stop = asyncio.Event()
    workers = [
        asyncio.create_task(_reader(scheduler, BODIES[i % len(BODIES)], i, stop))
        for i in range(callers)
    ]
    await asyncio.sleep(0.2 / scale)  # let the queue fill before the window opens
    start = clock.now()
    mark = sim.log.next_seq
    latencies: list[float] = []
    while clock.now() - start < seconds:
        submitted = clock.now()
        seq = sim.log.next_seq
        await scheduler.stop("1")
        stop_frame = next(
            r
            for r in sim.log.since(seq)
            if r.kind is RecordKind.HEARD and r.data.rstrip(b"\r").endswith(b"1S")
        )
        latencies.append(stop_frame.time - submitted)
        await asyncio.sleep(0.1 / scale)  # a stop every 100 ms of device time
    end = clock.now()
    stop.set()
    await asyncio.gather(*workers, return_exceptions=True)
    records = [r for r in sim.log.since(mark) if start <= r.time <= end]
    await scheduler.close()
    sim.close()
    char = BITS_PER_CHAR / baud
    heard = [r for r in records if r.kind is RecordKind.HEARD and r.ref > 0]
    replies = [r for r in records if r.kind is RecordKind.REPLY]
    busy = (
        sum(len(r.data) for r in heard) * char
        + sum(len(r.data) for r in replies) * char
        + len(replies) * sim.turnaround
    )
    return {
        "baud": baud,
        "time_scale": scale,
        "device_seconds": round(end - start, 3),
        "frames": len(heard),
        "replies": len(replies),
        "line_efficiency": round(busy / (end - start), 4),
        "target": 0.97,
        # The scheduler's own share of the gaps: real time from a reply's last byte read to
        # the next frame written (the rest of the idle time is the simulator's timers).
        "host_gap_ms_p50": round(statistics.median(transport.host_gaps) * 1000, 3),
        # What the line would carry if only the scheduler's own gaps stood between frames.
        "scheduler_efficiency": round(
            busy / (busy + len(heard) * statistics.mean(transport.host_gaps) * scale), 4
        ),
        "host_gap_ms_p99": round(_percentile(transport.host_gaps, 0.99) * 1000, 3),
        "stops": len(latencies),
        "stop_latency_ms_p50": round(statistics.median(latencies) * 1000, 2),
        "stop_latency_ms_p99": round(_percentile(latencies, 0.99) * 1000, 2),
        "scheduler": {
            "retries": scheduler.counters.retries,
            "timeouts": scheduler.counters.timeouts,
            "coalesced": scheduler.counters.coalesced,
        },
    }


def main() -> None:
    """Parse the options, run, print JSON."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="device seconds measured")
    parser.add_argument("--time-scale", type=float, default=1.0)
    parser.add_argument("--baud", type=int, default=9600, choices=list(BAUD_RATES))
    parser.add_argument("--callers", type=int, default=12, help="concurrent readers")
    args = parser.parse_args()
    figures = asyncio.run(measure(args.seconds, args.time_scale, args.baud, args.callers))
    print(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
