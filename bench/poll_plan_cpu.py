"""What choosing the next poll costs: the poller's stage of one exchange, in process.

``bench/exchange_profile.py`` profiles ``serve``'s own process, and the line (scheduler,
poller, state cache) now runs in a line worker it does not see. This runs the line worker's
part alone, as the tests do: the real ``LoopScheduler``, ``StateCache`` and ``Poller`` on the
in-process simulator (``PipeTransport``, real time, 9600 bps), 15 controllers, nothing asked
(``idle``) or one axis moving the whole window (``watch``: its position stream and the
spaced idle polls). Under ``cProfile`` with a CPU clock, every function's own time is summed
by stage: ``poller`` is ``poller.py``, ``poll_plan.py``, ``position_stream.py`` and
``due_queue.py`` (the stage of ``exchange_profile.py``), and ``pick`` is the plan's ``pick``
with everything it calls. Divided by the frames written (``Counters.exchanges``). A second
window without the profiler gives the process's real CPU an exchange (simulator included) and,
in ``watch``, the position reads of the moving axis a second (9600 bps, 14 idle controllers).

    .venv/bin/python bench/poll_plan_cpu.py --seconds 20
    .venv/bin/python bench/poll_plan_cpu.py --seconds 20 --src /tmp/base   # another tree
"""

from __future__ import annotations

import argparse
import asyncio
import cProfile
import json
import os
import pstats
import sys
import time
from pathlib import Path
from typing import Any

BODIES = "0123456789ABCDE"
POLLER_FILES = ("bus/poller.py", "bus/poll_plan.py", "bus/position_stream.py", "bus/due_queue.py")


async def window(seconds: float, mode: str, profile: cProfile.Profile | None) -> dict[str, Any]:
    from gateway.bus.config import LoopConfig
    from gateway.bus.poller import attach
    from gateway.bus.requests import Priority
    from gateway.bus.scheduler import LoopScheduler
    from gateway.bus.state import StateCache
    from gateway.protocol.command_text import parse
    from gateway.sim.cli import build_loop
    from gateway.sim.clock import SimClock
    from gateway.sim.serve import SimPort
    from gateway.transport.pipe import PipeTransport

    sim = build_loop(list(BODIES), clock=SimClock(1.0))
    scheduler = LoopScheduler(
        PipeTransport(lambda: SimPort(sim), url="pipe://sim"), LoopConfig(name="L")
    )
    state = StateCache()
    poller = attach(scheduler, state, list(BODIES))
    await scheduler.start()
    poller.start()
    # Every controller identified (its framing read) before the window.
    while not all(state.controller("L", b).framing for b in BODIES):
        await asyncio.sleep(0.1)
    if mode == "watch":  # 2,000,000 pulses at 5,000 pps: longer than any window
        await scheduler.submit("7", [parse("22000000"), parse("31")], priority=Priority.OPERATOR)
        await asyncio.sleep(0.5)
    start_exchanges = scheduler.counters.exchanges
    start_reads = poller.position_reads
    cpu = time.process_time()
    if profile is not None:
        profile.enable()
    await asyncio.sleep(seconds)
    if profile is not None:
        profile.disable()
    cpu = time.process_time() - cpu
    exchanges = scheduler.counters.exchanges - start_exchanges
    reads = poller.position_reads - start_reads
    await poller.stop()
    await scheduler.close()
    sim.close()
    return {"exchanges": exchanges, "cpu_s": cpu, "position_reads": reads}


def stages(profile: cProfile.Profile, exchanges: int) -> dict[str, float]:
    raw: dict[Any, Any] = pstats.Stats(profile).stats  # type: ignore[attr-defined]
    poller = 0.0
    pick = 0.0
    for (path, _line, name), (_cc, _nc, own, cumulative, _callers) in raw.items():
        if any(path.endswith(f) for f in POLLER_FILES):
            poller += own
        if name == "pick" and path.endswith("bus/poll_plan.py"):
            pick += cumulative
    return {
        "poller_us_per_exchange": round(poller / exchanges * 1e6, 1),
        "pick_us_per_exchange": round(pick / exchanges * 1e6, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--mode", choices=["idle", "watch"], default="idle")
    parser.add_argument("--src", type=Path, help="import the gateway from this source tree")
    args = parser.parse_args()
    if args.src is not None:
        sys.path.insert(0, str(args.src.resolve()))
    import gateway

    load = os.getloadavg()[0]
    profile = cProfile.Profile(time.process_time)
    profiled = asyncio.run(window(args.seconds, args.mode, profile))
    plain = asyncio.run(window(args.seconds, args.mode, None))
    result = {
        "tree": str(Path(gateway.__file__).parent.parent),
        "mode": args.mode,
        "load_average": [round(load, 2), round(os.getloadavg()[0], 2)],
        "exchanges_per_s": round(plain["exchanges"] / args.seconds, 1),
        "position_reads_per_s": round(plain["position_reads"] / args.seconds, 1),
        **stages(profile, profiled["exchanges"]),
        "profiled_exchanges": profiled["exchanges"],
        "process_cpu_us_per_exchange": round(plain["cpu_s"] / plain["exchanges"] * 1e6, 1),
    }
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
