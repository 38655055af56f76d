"""How one gateway scales with its loops: 1, 2, 4, 6, 8 loops of 15 controllers, from outside.

For each count of loops: that many ``rc233-gateway sim --tcp`` processes at real time (15
controllers each, 9600 bps), each behind its own stamping proxy (``outside_parts.py proxy``,
a process per loop), and one ``rc233-gateway serve`` on all of them. First the gateway idles
(the poller alone): the CPU of all its processes (the serve process and every child, found
through ``/proc``, so line workers count); then ``--callers`` HTTP clients per loop keep every
loop's queue full of ``POST /loops/{loop}/raw`` reads: each loop's line efficiency from its
proxy's record (Σ ideal wire time of frame and reply + 1 ms turnaround, over elapsed) and the
gateway's CPU again. It prints one JSON object (with the load average) and, with
``--plot FILE`` and matplotlib installed (``pip install -e '.[bench]'``), draws it.

    .venv/bin/python bench/line_scale.py                        # 1,2,4,6,8 loops, 10 s a phase
    .venv/bin/python bench/line_scale.py --loops 1,2 --seconds 2   # what make bench runs
    .venv/bin/python bench/line_scale.py --plot docs/images/line_scale.png
    .venv/bin/python bench/line_scale.py --src /tmp/before   # another tree (git archive)
    .venv/bin/python bench/line_scale.py --from-json after.json --before before.json --plot x.png
"""

from __future__ import annotations

import argparse
import asyncio
import itertools
import json
import os
import signal
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from line_outside import CLI, PARTS, Bench, free_port, tree_cpu, wait_ready
from line_outside import _exchange as http_exchange
from outside_record import exchanges

BODIES = "0123456789ABCDE"
READS = ("OH", "OL", "CL", "2D", "OX")


def config(loops: list[tuple[str, int]]) -> str:
    text = ""
    for k, (name, port) in enumerate(loops):
        text += f'[[loops]]\nname = "{name}"\nport = "socket://127.0.0.1:{port}"\n'
        for b in BODIES:
            axis = "x" if (k, b) == (0, "1") else f"l{k}a{b}"
            text += (
                f'[[loops.controllers]]\nbody = "{b}"\nname = "l{k}c{b}"\n'
                f'[[loops.controllers.axes]]\nmotor = 1\nname = "{axis}"\n'
            )
    return text


async def keep_full(port: int, loop: str, n: int, done: asyncio.Event) -> None:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    i = n
    while not done.is_set():
        body = {"controller": BODIES[i % len(BODIES)], "text": READS[i % len(READS)]}
        path = f"/api/v1/loops/{loop}/raw"
        status, text = await http_exchange(reader, writer, "POST", path, body)
        assert status == 200, text
        i += 1
    writer.close()


def efficiency(rows: list[Any], loop: str, start: float, end: float) -> dict[str, Any]:
    inside = [e for e in exchanges(rows, loop) if start <= e.sent and e.reply_end <= end]
    busy = sum(e.ideal for e in inside)
    gaps = sorted(
        after.sent - before.reply_end
        for before, after in itertools.pairwise(inside)
        if before.reply_end
    )
    return {
        "exchanges": len(inside),
        "efficiency": round(busy / (end - start), 4),
        "gap_ms_p50": round(gaps[len(gaps) // 2] * 1000, 3) if gaps else None,
        "gap_ms_p99": round(gaps[int(0.99 * (len(gaps) - 1))] * 1000, 3) if gaps else None,
    }


async def one_count(
    bench: Bench, count: int, seconds: float, callers: int, idle_only: bool = False
) -> dict[str, Any]:
    loops = [(f"l{k}", free_port()) for k in range(count)]
    records = []
    proxies = []
    for name, listen in loops:
        upstream = free_port()
        bench.sim(upstream, ",".join(BODIES))
        record = bench.tmp / f"{name}-{count}.jsonl"
        records.append(record)
        proxies.append(
            bench.start(
                PARTS, "proxy", "--out", str(record), "--pair", f"{name}:{listen}:{upstream}",
                ready="ready", log=f"proxy-{name}-{count}",
            )
        )  # fmt: skip
    cell = bench.tmp / f"scale{count}.toml"
    cell.write_text(config(loops))
    http_port = free_port()
    serve = bench.start(
        *CLI, "serve", "--config", str(cell), "--no-auth", "--port", str(http_port),
        ready="rc233-gateway serve", log=f"serve{count}",
    )  # fmt: skip
    await wait_ready(http_port, "/api/v1/axes/x", timeout=120)
    await asyncio.sleep(3.0)  # every controller learnt, the poller at its idle pace
    load = os.getloadavg()[0]
    idle = (time.monotonic(), *tree_cpu(serve.pid))
    await asyncio.sleep(seconds)
    idle_end = (time.monotonic(), *tree_cpu(serve.pid))
    done = asyncio.Event()
    tasks = [
        asyncio.create_task(keep_full(http_port, name, n, done))
        for name, _ in loops
        for n in range(0 if idle_only else callers)
    ]
    await asyncio.sleep(1.0)  # queues full
    full = (time.monotonic(), *tree_cpu(serve.pid))
    await asyncio.sleep(seconds)
    full_end = (time.monotonic(), *tree_cpu(serve.pid))
    done.set()
    await asyncio.gather(*tasks)
    bench.stop(serve)
    rows: list[Any] = []
    for proxy, record in zip(proxies, records, strict=True):
        bench.stop(proxy)
        rows += [json.loads(line) for line in record.read_text().splitlines()]
    for proc in [p for p in bench.procs if p.poll() is None]:
        bench.stop(proc)  # this count's simulators
    per_loop = {name: efficiency(rows, name, full[0], full_end[0]) for name, _ in loops}
    if idle_only:
        per_loop = {name: efficiency(rows, name, idle[0], idle_end[0]) for name, _ in loops}
    worst = min(per_loop.values(), key=lambda figures: figures["efficiency"])
    return {
        "loops": count,
        "load_average": round(load, 2),
        "gateway_processes": full_end[2],
        "idle_cpu_percent": round((idle_end[1] - idle[1]) / (idle_end[0] - idle[0]) * 100, 2),
        "idle_exchanges_per_s": round(
            sum(figures["exchanges"] for figures in per_loop.values()) / seconds, 1
        )
        if idle_only
        else None,
        "idle_cpu_percent_a_loop": round(
            (idle_end[1] - idle[1]) / (idle_end[0] - idle[0]) * 100 / count, 2
        ),
        "full_cpu_percent": round((full_end[1] - full[1]) / (full_end[0] - full[0]) * 100, 2),
        "worst_loop_efficiency": worst["efficiency"],
        "per_loop": per_loop,
    }


def plot(results: list[dict[str, Any]], out: Path, before: list[dict[str, Any]] | None) -> None:
    import matplotlib  # bench-only and optional: imported when drawing

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    counts = [r["loops"] for r in results]
    fig, (eff, cpu) = plt.subplots(1, 2, figsize=(10, 4))
    for r in results:
        values = [figures["efficiency"] for figures in r["per_loop"].values()]
        eff.scatter([r["loops"]] * len(values), values, color="tab:blue", s=12)
    eff.plot(counts, [r["worst_loop_efficiency"] for r in results], color="tab:blue",
             label="worst loop")  # fmt: skip
    if before:
        eff.plot([r["loops"] for r in before], [r["worst_loop_efficiency"] for r in before],
                 color="grey", linestyle=":", marker="x", label="worst loop, before")  # fmt: skip
    eff.axhline(0.95, color="tab:red", linestyle="--", label="target 0.95")
    eff.set(xlabel="loops of 15 controllers", ylabel="line efficiency", ylim=(0.5, 1.0),
            title="each loop's queue kept full over HTTP")  # fmt: skip
    eff.legend()
    cpu.plot(counts, [r["full_cpu_percent"] for r in results], marker="o", label="queues full")
    cpu.plot(counts, [r["idle_cpu_percent"] for r in results], marker="o", label="idle")
    if before:
        cpu.plot([r["loops"] for r in before], [r["full_cpu_percent"] for r in before],
                 color="grey", linestyle=":", marker="x", label="queues full, before")  # fmt: skip
        cpu.plot([r["loops"] for r in before], [r["idle_cpu_percent"] for r in before],
                 color="grey", linestyle="--", marker="x", label="idle, before")  # fmt: skip
    cpu.plot(counts, counts, color="tab:red", linestyle="--", label="target idle: 1 % a loop")
    cpu.set(xlabel="loops of 15 controllers", ylabel="% of a core, all gateway processes",
            title="gateway CPU")  # fmt: skip
    cpu.legend(fontsize=8)
    for axes in (eff, cpu):
        axes.set_xticks(counts)
    loads = ", ".join(str(r["load_average"]) for r in results)
    fig.suptitle(f"one gateway, 9600 bps loops at real time (load average {loads})", fontsize=9)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)


async def run(args: argparse.Namespace) -> list[dict[str, Any]]:
    results = []
    for count in [int(n) for n in args.loops.split(",")]:
        with tempfile.TemporaryDirectory(prefix="line-scale-") as tmp:
            bench = Bench(args.src, args.python, Path(tmp))
            try:
                figures = await one_count(bench, count, args.seconds, args.callers, args.idle_only)
                results.append(figures)
            finally:
                bench.close()
        print(json.dumps(results[-1]), file=sys.stderr, flush=True)
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--loops", default="1,2,4,6,8", help="loop counts, comma-separated")
    parser.add_argument("--seconds", type=float, default=10.0, help="seconds a phase")
    parser.add_argument("--callers", type=int, default=4, help="HTTP clients a loop")
    parser.add_argument("--plot", type=Path, help="draw the figures (PNG; needs matplotlib)")
    parser.add_argument("--python", default=sys.executable, help="the gateway's Python")
    parser.add_argument("--src", type=Path, help="run the gateway from this source tree")
    parser.add_argument("--before", type=Path, help="an earlier run's JSON, drawn beside")
    parser.add_argument("--idle-only", action="store_true", help="no HTTP load phase")
    parser.add_argument("--from-json", type=Path, help="draw this run's JSON, run nothing")
    args = parser.parse_args()
    signal.signal(signal.SIGTERM, signal.default_int_handler)  # the processes are closed
    before = json.loads(args.before.read_text())["runs"] if args.before else None
    if args.from_json is not None:  # draw an earlier run again
        results = json.loads(args.from_json.read_text())["runs"]
        if args.plot is not None:
            plot(results, args.plot, before)
        return
    results = asyncio.run(run(args))
    targets = {"worst_loop_efficiency": ">= 0.95", "idle_cpu_percent_a_loop": "<= 1.0"}
    print(json.dumps({"runs": results, "targets": targets}, indent=2))
    if args.plot is not None:
        plot(results, args.plot, before)


if __name__ == "__main__":
    main()
