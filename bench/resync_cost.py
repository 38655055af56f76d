"""What bringing the line back in step after a lost reply costs in line time.

The simulated loop runs at the line's real character timing (9600 bps); one
scheduler reads position table entries back to back, first on a clean line, then with a share
of the replies late (the simulator's ``late`` fault, ``--delay`` device seconds). After every
time-out the link waits until the line has been quiet for the longest reply of the loop
(``Timing.resync_quiet``); the figures say what that costs:

* ``resync_ms``: the mean host time one resync held the line (from the time-out on);
* ``resync_quiet_ms``: the silence it waits for, as computed from the baud rate;
* ``reads_per_s_clean`` / ``reads_per_s_late``: the reads answered per second either way;
* ``line_ms_per_fault``: the line time each faulty reply cost, all told (time-out and
  resync), from the two rates.

    .venv/bin/python bench/resync_cost.py                      # 20 % late, 90 ms, 400 reads
    .venv/bin/python bench/resync_cost.py --kind drop          # 20 % lost: the full silence

It prints one JSON object. Every read is checked against the value written (a wrong one
stops the bench).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import tempfile
import time
from pathlib import Path
from typing import Any

from gateway.bus.config import LoopConfig
from gateway.bus.scheduler import LoopScheduler
from gateway.protocol.command_text import parse
from gateway.sim.cli import build_loop
from gateway.sim.clock import SimClock
from gateway.sim.faults import FaultKind, FaultRule, Faults
from gateway.sim.serve import SimPort
from gateway.transport.pipe import PipeTransport

ENTRIES = 10


async def _reads(scheduler: LoopScheduler, count: int) -> tuple[float, int]:
    """``count`` entry reads; the elapsed seconds and how many were answered."""
    answered = 0
    began = time.perf_counter()
    for i in range(count):
        n = i % ENTRIES
        result = await scheduler.submit("1", parse(f"A{n:03d}D"))
        if result.value is not None:
            if result.value != 1000 + n:
                raise SystemExit(f"entry {n}: {result.value}, not {1000 + n}")
            answered += 1
    return time.perf_counter() - began, answered


async def run(
    reads: int, probability: float, delay: float, baud: int, kind: FaultKind
) -> dict[str, Any]:
    eeproms = tempfile.TemporaryDirectory()
    sim = build_loop(["1"], clock=SimClock(1.0, precise=True), eeprom_dir=Path(eeproms.name))
    transport = PipeTransport(lambda: SimPort(sim), baud=baud)
    scheduler = LoopScheduler(transport, LoopConfig(baud=baud, resend_retries=0))
    await scheduler.start()
    try:
        await scheduler.submit("1", [parse(f"A{n:03d}{1000 + n}") for n in range(ENTRIES)])
        clean, clean_ok = await _reads(scheduler, reads)
        faults = Faults(seed=5)
        faults.add(FaultRule(kind, probability=probability, delay=delay))
        sim.act(lambda now: setattr(sim, "faults", faults))
        resyncs, held = scheduler.resync_figures()
        before = scheduler.snapshot()
        late, late_ok = await _reads(scheduler, reads)
        after = scheduler.snapshot()
        resyncs_after, held_after = scheduler.resync_figures()
        n_resync = resyncs_after - resyncs
        late_replies = after.late_replies - before.late_replies
        per_clean, per_late = clean / reads, late / reads
        return {
            "baud": baud,
            "reads": reads,
            "fault": kind.value,
            "probability": probability,
            "late_delay_s": delay,
            "resync_quiet_ms": round(scheduler.timing.resync_quiet() * 1000, 1),
            "resyncs": n_resync,
            "resync_ms": round((held_after - held) / max(1, n_resync) * 1000, 1),
            "late_replies": late_replies,
            "timeouts": after.timeouts - before.timeouts,
            "answered_clean": clean_ok,
            "answered_late": late_ok,
            "reads_per_s_clean": round(reads / clean, 1),
            "reads_per_s_late": round(reads / late, 1),
            "line_ms_per_fault": round((per_late - per_clean) * reads / max(1, n_resync) * 1000, 1),
        }
    finally:
        await scheduler.close()
        sim.close()
        eeproms.cleanup()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reads", type=int, default=400)
    parser.add_argument("--probability", type=float, default=0.2)
    parser.add_argument("--delay", type=float, default=0.09, help="device seconds")
    parser.add_argument("--kind", choices=["late", "drop"], default="late", help="the fault")
    args = parser.parse_args()
    figures = asyncio.run(run(args.reads, args.probability, args.delay, 9600, FaultKind(args.kind)))
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
