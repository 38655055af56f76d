"""What one exchange costs the gateway, stage by stage: every process of ``serve`` under cProfile.

``rc233-gateway sim --tcp`` at real time with 15 controllers, and ``rc233-gateway serve`` on
that loop, every process of it (the API process and its line workers) run under ``cProfile``
with a CPU clock: a ``sitecustomize`` put first on the gateway's ``PYTHONPATH`` arms a profiler
in each, switched on for the window by SIGUSR1 and written out by SIGUSR2 (start-up is not in
it). Two runs: ``idle`` (nothing asked, the poller alone) and ``full`` (``--callers`` HTTP
clients keep the queue full of ``POST /loops/main/raw`` reads). Each process's own CPU
(``/proc``) over the window and the exchanges (calls of ``Link._write``, in the worker) give
the CPU an exchange; the profile's own time of every function, summed by the stage its module
belongs to, splits it, per process (the profiler's overhead inflates every stage alike, so the
shares are the figure, and the unprofiled CPU is ``line_scale.py``'s).

    .venv/bin/python bench/exchange_profile.py --seconds 10
    .venv/bin/python bench/exchange_profile.py --mode idle --top 30   # and the hottest functions
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import pstats
import shutil
import signal
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from line_outside import CLI, Bench, cpu_seconds, descendants, free_port, wait_ready
from line_outside import _exchange as http_exchange

#: Stages, first match wins: (name, fragments of a module path or function name).
STAGES: list[tuple[str, tuple[str, ...]]] = [
    ("encode", ("protocol/framing.py", "protocol/models.py", "protocol/commands.py",
                "bus/timing.py")),
    ("write", ("transport/", "selector_events.py:write", "link.py:_write")),
    ("read/parse", ("bus/receiver.py", "protocol/reply_parser.py", "protocol/command_replies.py",
                    "protocol/replies.py", "protocol/reply_values.py", "protocol/reply_decode")),
    ("state cache", ("bus/state.py", "bus/state_types.py", "bus/readings.py", "bus/latches.py",
                     "bus/origin.py", "bus/programs_seen.py")),
    ("events/publication", ("bus/events.py", "service/", "api/ws", "api/feed", "mqtt/")),
    ("trace", ("bus/trace.py",)),
    ("counters", ("bus/counters.py", "bus/counting.py", "metrics")),
    ("scheduler", ("bus/scheduler.py", "bus/queue.py", "bus/transaction.py", "bus/exchange.py",
                   "bus/link.py", "bus/lateness.py", "bus/selection.py", "bus/framing_track.py",
                   "bus/requests.py", "bus/retries.py", "bus/read_back.py", "bus/lifecycle.py",
                   "bus/stop_lane.py", "bus/line_health.py")),
    ("poller", ("bus/poller.py", "bus/poll_plan.py", "bus/position_stream.py", "bus/due_queue.py")),
    ("HTTP", ("uvicorn", "starlette", "fastapi", "httptools", "h11", "gateway/api/", "pydantic")),
    ("event loop", ("asyncio/", "uvloop", "<built-in method select", "epoll", "selectors.py")),
]  # fmt: skip

#: Put first on the gateway's ``PYTHONPATH``: every Python process started with it (the serve
#: process, its line workers) arms a profiler of CPU time (not wall time: the event loop's
#: waits are no cost), switched on by SIGUSR1 and written to ``DIR/PID.prof`` by SIGUSR2.
SITECUSTOMIZE = """
import cProfile, os, signal, time
_profile = cProfile.Profile(time.process_time)
def _dump(*_):
    _profile.disable()
    _profile.dump_stats(os.path.join({out!r}, f"{{os.getpid()}}.prof"))
signal.signal(signal.SIGUSR1, lambda *_: _profile.enable())
signal.signal(signal.SIGUSR2, _dump)
"""


def stage_of(key: tuple[str, int, str]) -> str:
    where = f"{key[0]}:{key[2]}"
    for name, parts in STAGES:
        if any(part in where for part in parts):
            return name
    return "other"


def split(stats: pstats.Stats, top: int) -> tuple[int, dict[str, float], list[tuple[str, float]]]:
    """Exchanges, own seconds by stage, and the ``top`` functions by own time."""
    raw: dict[Any, Any] = stats.stats  # type: ignore[attr-defined]
    exchanges = 0
    stages: dict[str, float] = {}
    functions = []
    for key, (_cc, calls, own, _cum, callers) in raw.items():
        if key[0].endswith("bus/link.py") and key[2] == "_write":
            # a plain function, one call a frame (a coroutine counts a call per resumption)
            exchanges = calls
        stage = stage_of(key)
        if stage == "other" and key[0] == "~" and callers:
            # A built-in (isinstance, dict.get ...) is its callers' cost, shared by calls.
            every = sum(numbers[1] for numbers in callers.values()) or 1
            for caller, numbers in callers.items():
                share = stage_of(caller)
                stages[share] = stages.get(share, 0.0) + own * numbers[1] / every
        else:
            stages[stage] = stages.get(stage, 0.0) + own
        functions.append((f"{Path(key[0]).name}:{key[1]}:{key[2]} [{stage}] x{calls}", own))
    functions.sort(key=lambda item: -item[1])
    return exchanges, stages, functions[:top]


async def keep_full(port: int, callers: int, bodies: list[str], done: asyncio.Event) -> None:
    async def caller(n: int) -> None:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        i = n
        while not done.is_set():
            body = {"controller": bodies[i % len(bodies)], "text": ("OH", "OL", "CL")[i % 3]}
            await http_exchange(reader, writer, "POST", "/api/v1/loops/main/raw", body)
            i += 1
        writer.close()

    await asyncio.gather(*(caller(n) for n in range(callers)))


async def one_run(
    bench: Bench, mode: str, seconds: float, callers: int, top: int, keep: Path | None
) -> dict[str, Any]:
    sim_port, http_port = free_port(), free_port()
    bodies = list("0123456789ABCDE")
    bench.sim(sim_port, ",".join(bodies))
    out = bench.tmp / f"{mode}-profiles"
    site = bench.tmp / f"{mode}-site"
    out.mkdir()
    site.mkdir()
    (site / "sitecustomize.py").write_text(SITECUSTOMIZE.format(out=str(out)))
    before = bench.env.get("PYTHONPATH")
    bench.env["PYTHONPATH"] = os.pathsep.join(p for p in (str(site), before) if p)
    controllers = "".join(
        f'\n[[loops.controllers]]\nbody = "{b}"\nname = "c{b}"\n[[loops.controllers.axes]]\n'
        f'motor = 1\nname = "{"x" if b == "1" else "a" + b}"\n'
        for b in bodies
    )
    cell = bench.tmp / f"{mode}.toml"
    cell.write_text(
        f'[[loops]]\nname = "main"\nport = "socket://127.0.0.1:{sim_port}"\n{controllers}'
    )
    proc = bench.start(
        *CLI, "serve", "--config", str(cell), "--no-auth",
        "--port", str(http_port), ready="rc233-gateway serve", log=f"serve-{mode}",
    )  # fmt: skip
    if before is None:
        del bench.env["PYTHONPATH"]
    else:
        bench.env["PYTHONPATH"] = before
    await wait_ready(http_port, "/api/v1/axes/x")
    await asyncio.sleep(8.0)  # past the first reads of every controller (they change the state)
    done = asyncio.Event()
    load = None
    if mode == "full":
        load = asyncio.create_task(keep_full(http_port, callers, bodies, done))
    await asyncio.sleep(0.5)
    pids = descendants(proc.pid)  # the serve process and its line workers
    for pid in pids:
        os.kill(pid, signal.SIGUSR1)
    start = (time.monotonic(), {pid: cpu_seconds(pid) for pid in pids}, os.getloadavg()[0])
    await asyncio.sleep(seconds)
    end = (time.monotonic(), {pid: cpu_seconds(pid) for pid in pids})
    for pid in pids:
        os.kill(pid, signal.SIGUSR2)
    done.set()
    if load is not None:
        await load
    files = [out / f"{pid}.prof" for pid in pids]
    while not all(f.exists() for f in files):
        await asyncio.sleep(0.1)
    await asyncio.sleep(0.5)  # written
    bench.stop(proc)
    split_by = {pid: split(pstats.Stats(str(f)), top) for pid, f in zip(pids, files, strict=True)}
    if keep is not None:
        for f in files:
            shutil.copy(f, keep / f"{mode}-{f.name}")
    exchanges = max(1, sum(figures[0] for figures in split_by.values()))
    elapsed = end[0] - start[0]
    processes = {}
    for pid, (_, stages, functions) in split_by.items():
        name = "api" if pid == proc.pid else f"worker {pid}"
        cpu = end[1][pid] - start[1][pid]
        processes[name] = {
            "profiled_cpu_percent": round(cpu / elapsed * 100, 2),
            "cpu_ms_per_exchange_profiled": round(cpu / exchanges * 1e3, 3),
            # CPU seconds the profile saw in Python functions (the profiler's own cost is not
            # in them; the process's CPU above includes it).
            "us_per_exchange_in_profile": round(sum(stages.values()) / exchanges * 1e6, 1),
            "stages_us_per_exchange": {
                stage: round(own / exchanges * 1e6, 1)
                for stage, own in sorted(stages.items(), key=lambda item: -item[1])
            },
            "top": [f"{round(own / exchanges * 1e6, 1)} us  {fn}" for fn, own in functions],
        }
    return {
        "mode": mode,
        "load_average": round(start[2], 2),
        "exchanges": exchanges,
        "processes": processes,
    }


async def run(args: argparse.Namespace) -> list[dict[str, Any]]:
    results = []
    modes = ["idle", "full"] if args.mode == "both" else [args.mode]
    for mode in modes:
        with tempfile.TemporaryDirectory(prefix="exchange-profile-") as tmp:
            bench = Bench(args.src, args.python, Path(tmp))
            try:
                figures = await one_run(
                    bench, mode, args.seconds, args.callers, args.top, args.keep
                )
                results.append(figures)
            finally:
                bench.close()
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--mode", choices=["idle", "full", "both"], default="both")
    parser.add_argument("--callers", type=int, default=12)
    parser.add_argument("--top", type=int, default=0, help="also the N hottest functions")
    parser.add_argument("--src", type=Path, help="run the gateway from this source tree")
    parser.add_argument("--keep", type=Path, help="copy the profiles (pstats) to this directory")
    parser.add_argument("--python", default=sys.executable, help="the gateway's Python")
    args = parser.parse_args()
    print(json.dumps(asyncio.run(run(args)), indent=2))


if __name__ == "__main__":
    main()
