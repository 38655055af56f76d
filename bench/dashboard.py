"""What the dashboard costs a browser: 30 axes changing 20 times a second, in headless Chromium.

A server process runs the real app (``create_app``) on an in-process simulated loop of 15
controllers (30 axes, real-time line timing, the poller running) under uvicorn on 127.0.0.1,
and feeds position replies for every axis ``--rate`` times a second into the gateway's state
cache, as the scheduler does: the WebSocket feed publishes each as a change, and the page
(the real dashboard at ``/``, Debian's ``/usr/bin/chromium`` at 1280x800) draws them.

It prints one JSON object:

* ``frames``: animation frames the page got during the run, and ``dropped``: frames missed
  (a gap between two frames of more than 1.5 x 16.7 ms counts its missing frames);
* ``long_tasks``: main-thread tasks over 50 ms (the Long Tasks API), their count and the
  longest (target: none);
* ``ws_frames``: WebSocket messages the page received (should be axes x rate x seconds plus
  what the poller adds);
* ``page_main_thread``: the renderer main thread's busy fraction (CDP ``TaskDuration``);
* ``browser_cpu``: CPU seconds of every Chromium process per wall second (1.0 = one core).

    .venv/bin/python bench/dashboard.py                  # 30 s
    .venv/bin/python bench/dashboard.py --seconds 5      # what make bench runs
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

# The browser as the tests start it (one definition: tests/support/chromium.py).
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.support.chromium import CHROMIUM, CHROMIUM_ARGS

BODIES = [f"{n:X}" for n in range(15)]  # 0-E: 15 controllers, 30 axes

# Injected before the page's own scripts: frame gaps and long tasks, read back at the end.
PROBE = """
window.__bench = { frames: 0, dropped: 0, longTasks: [], last: 0, on: false };
(() => {
  const b = window.__bench;
  const tick = (t) => {
    if (b.on) {
      if (b.last) {
        const gap = t - b.last;
        if (gap > 16.7 * 1.5) b.dropped += Math.round(gap / 16.7) - 1;
      }
      b.frames += 1;
      b.last = t;
    }
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
  new PerformanceObserver((list) => {
    for (const e of list.getEntries()) if (b.on) b.longTasks.push(e.duration);
  }).observe({ entryTypes: ["longtask"] });
})();
"""


async def serve() -> None:
    """The server process: the app on 15 simulated controllers; prints its port."""
    import uvicorn
    from fastapi import FastAPI

    from gateway.api.app import API_PREFIX, create_app
    from gateway.api.security import AuthConfig
    from gateway.api.ws import endpoint as ws
    from gateway.bus.events import ReplyObserved
    from gateway.compose import compose
    from gateway.protocol.command_text import parse
    from gateway.service.runtime.runtime import Runtime
    from gateway.service.runtime.simulated import SIM_LOOP, simulated_config
    from gateway.sim.cli import build_loop
    from gateway.sim.clock import SimClock
    from gateway.sim.serve import SimPort
    from gateway.transport.pipe import PipeTransport

    sim = build_loop(BODIES, clock=SimClock(1.0))
    config = simulated_config(BODIES)
    gateway = Runtime(config, transports={SIM_LOOP: PipeTransport(lambda: SimPort(sim))})
    app: FastAPI = create_app(compose(gateway), auth=AuthConfig(no_auth=True))
    reads = {1: parse("61"), 2: parse("62")}
    tasks: set[asyncio.Task[None]] = set()

    async def inject(rate: float, seconds: float) -> None:
        start = due = time.monotonic()
        n = 0
        while time.monotonic() - start < seconds:
            n += 1
            for i, body in enumerate(BODIES):
                for motor in (1, 2):
                    # a slow sine per axis: every reading differs from the one before
                    value = 50_000 + int(20_000 * ((n + 7 * i + 3 * motor) % 200) / 200)
                    gateway.state.handle(
                        ReplyObserved(
                            loop=SIM_LOOP,
                            time=time.monotonic(),
                            body=body,
                            command=reads[motor],
                            value=value,
                        )
                    )
            due += 1 / rate
            await asyncio.sleep(max(0.0, due - time.monotonic()))

    @app.post(f"{API_PREFIX}/bench/inject")
    async def start_injecting(rate: float, seconds: float) -> dict[str, bool]:
        task = asyncio.create_task(inject(rate, seconds))
        tasks.add(task)
        task.add_done_callback(tasks.discard)
        return {"started": True}

    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(("127.0.0.1", 0))
    sock.listen(128)
    options = ws.uvicorn_ws_options(config.ws)
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", **options))
    print(sock.getsockname()[1], flush=True)
    await server.serve(sockets=[sock])


def chromium_cpu() -> float:
    """CPU seconds (user + system) of every Chromium process under this one."""
    tick = os.sysconf("SC_CLK_TCK")
    parents: dict[int, int] = {}
    stats: dict[int, tuple[str, float]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            raw = (entry / "stat").read_text()
        except OSError:
            continue
        name = raw[raw.index("(") + 1 : raw.rindex(")")]
        fields = raw[raw.rindex(")") + 2 :].split()
        parents[int(entry.name)] = int(fields[1])
        stats[int(entry.name)] = (name, (int(fields[11]) + int(fields[12])) / tick)
    me = os.getpid()

    def descends(pid: int) -> bool:
        while pid > 1:
            pid = parents.get(pid, 0)
            if pid == me:
                return True
        return False

    return sum(cpu for pid, (name, cpu) in stats.items() if "chrom" in name and descends(pid))


def run(args: argparse.Namespace) -> dict[str, Any]:
    import httpx
    from playwright.sync_api import sync_playwright

    child = subprocess.Popen(
        [sys.executable, __file__, "--serve"], stdout=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout is not None
        base = f"http://127.0.0.1:{int(child.stdout.readline())}"
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            page.add_init_script(PROBE)
            cdp = page.context.new_cdp_session(page)
            cdp.send("Performance.enable")
            cdp.send("Network.enable")
            ws_frames = [0]
            cdp.on(
                "Network.webSocketFrameReceived",
                lambda _: ws_frames.__setitem__(0, ws_frames[0] + 1),
            )
            page.goto(base + "/")
            page.locator("[data-axis]").nth(len(BODIES) * 2 - 1).wait_for(timeout=30_000)
            page.get_by_test_id("connection").filter(has_text="live").wait_for(timeout=30_000)

            def task_duration() -> float:
                metrics = cdp.send("Performance.getMetrics")["metrics"]
                return float(next(m["value"] for m in metrics if m["name"] == "TaskDuration"))

            page.evaluate("() => { window.__bench.on = true; }")
            ws_frames[0] = 0
            cpu0, task0, t0 = chromium_cpu(), task_duration(), time.monotonic()
            if args.profile:
                cdp.send("Profiler.enable")
                cdp.send("Profiler.start")
            httpx.post(
                f"{base}/api/v1/bench/inject",
                params={"rate": args.rate, "seconds": args.seconds},
                headers={"Content-Type": "application/json"},  # every act is declared JSON
            )
            page.wait_for_timeout(args.seconds * 1000)
            if args.profile:
                top_functions(cdp.send("Profiler.stop")["profile"])
            wall = time.monotonic() - t0
            cpu, task = chromium_cpu() - cpu0, task_duration() - task0
            probe = page.evaluate("() => { window.__bench.on = false; return window.__bench; }")
            browser.close()
    finally:
        child.terminate()
        child.wait(10)
    long_tasks = probe["longTasks"]
    return {
        "axes": len(BODIES) * 2,
        "rate": args.rate,
        "seconds": round(wall, 2),
        "frames": probe["frames"],
        "dropped": probe["dropped"],
        "long_tasks": {"count": len(long_tasks), "max_ms": round(max(long_tasks, default=0), 1)},
        "ws_frames": ws_frames[0],
        "page_main_thread": round(task / wall, 3),
        "browser_cpu": round(cpu / wall, 3),
        "cpus": os.cpu_count(),
    }


def top_functions(profile: dict[str, Any], count: int = 25) -> None:
    """Print the functions with the most self time of a CDP CPU profile (to stderr)."""
    nodes = {n["id"]: n for n in profile["nodes"]}
    self_time: dict[str, float] = {}
    deltas = profile["timeDeltas"]
    for sample, delta in zip(profile["samples"], deltas, strict=False):
        frame = nodes[sample]["callFrame"]
        name = f"{frame['functionName'] or '(anonymous)'} {frame['url'].rsplit('/', 1)[-1]}"
        name += f":{frame['lineNumber']}"
        self_time[name] = self_time.get(name, 0.0) + delta / 1000
    for name, ms in sorted(self_time.items(), key=lambda kv: -kv[1])[:count]:
        print(f"{ms:9.1f} ms  {name}", file=sys.stderr)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=30.0, help="real seconds")
    parser.add_argument("--rate", type=float, default=20.0, help="changes a second per axis")
    parser.add_argument("--profile", action="store_true", help="print the page's hot functions")
    parser.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)
    return parser.parse_args(argv)


if __name__ == "__main__":
    arguments = parse_args()
    if arguments.serve:
        asyncio.run(serve())
    else:
        print(json.dumps(run(arguments)))
