"""Does the gateway's memory stay flat under traffic? A soak from outside, for minutes or hours.

``rc233-gateway sim --tcp`` at real time (three controllers, 2 % of the replies faulted through
its control port: naks, garbled and dropped replies) and ``rc233-gateway serve --config`` on it
(``--no-auth``); this process is the clients: ``--ws-clients`` WebSocket clients subscribed to
every topic (``axis:*``, ``controller:*``, ``loop:*``, ``events``) reading all they get, and
``--rest`` HTTP clients on keep-alive connections mixing cached and fresh axis reads, moves,
speed changes, operations listed and read, leases taken and given back, each pausing
``--pause`` seconds between requests. Every minute it prints one JSON line: the resident
memory (RSS) and open descriptors of every gateway process (``serve`` and its children, the
line workers, from ``/proc``), the API process's asyncio tasks (``/metrics``), and the
p50/p99 of the cached ``GET /axes/x`` in that minute. At the end the clients leave, and it
prints the summary: peak RSS, the slope after ``--warmup`` minutes (least squares, MB an hour),
descriptors and tasks before the clients came and after they left, GET p99 in the first and
the last minute.

    .venv/bin/python bench/soak.py --minutes 120                # the target run: 2 hours
    .venv/bin/python bench/soak.py --minutes 3 --warmup 1       # what `make soak` runs
    .venv/bin/python bench/soak.py --minutes 30 --tracemalloc 5  # heap dumps every 5 minutes

``--tracemalloc N`` starts serve with ``RC233_TRACEMALLOC=1`` and sends it and its line
workers ``SIGUSR2`` every N minutes: the lines that allocated most since the previous dump land
in ``--heap-out`` (``gateway.heap_trace``), each dump naming its process. Tracing inflates
RSS: take the RSS figures from a run without it.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from line_outside import Bench, descendants, free_port, http, wait_ready
from line_outside import _exchange as exchange
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed

AXES = ("x", "a2", "a3")
TOPICS = ["axis:*", "controller:*", "loop:*", "events"]
#: 2 % of the replies faulted: what the line of the issue's figures saw
FAULTS = ({"kind": "nak", "probability": 0.01}, {"kind": "garble", "probability": 0.005},
          {"kind": "drop", "probability": 0.005})  # fmt: skip


def process_figures(pid: int) -> dict[str, Any]:
    """RSS (MB, in all and per process) and open descriptors of ``pid`` and every process
    below it (the line workers)."""
    each_mb: dict[str, float] = {}
    fds = 0
    for each in descendants(pid):
        try:
            status = Path(f"/proc/{each}/status").read_text()
            rss = next(int(line.split()[1]) * 1024 for line in status.splitlines()
                       if line.startswith("VmRSS:"))  # fmt: skip
            fds += len(os.listdir(f"/proc/{each}/fd"))
        except (OSError, StopIteration):
            continue  # gone meanwhile
        each_mb[str(each)] = round(rss / 1e6, 2)
    return {"rss_mb": round(sum(each_mb.values()), 2), "fds": fds, "processes": len(each_mb),
            "rss_mb_by_pid": each_mb}  # fmt: skip


def dump_heaps(pid: int) -> None:
    """Ask serve and every line worker under it for a heap dump (each traces its own)."""
    for each in descendants(pid):
        try:
            os.kill(each, signal.SIGUSR2)
        except ProcessLookupError:
            continue  # gone meanwhile


async def asyncio_tasks(port: int) -> int | None:
    """The API process's asyncio tasks, as ``/metrics`` gives them (None: not exposed)."""
    status, body = await http(port, "GET", "/metrics")
    if status != 200:
        return None
    for line in body.decode().splitlines():
        if line.startswith("rc233_process_asyncio_tasks{") and 'role="api"' in line:
            return int(float(line.rsplit(" ", 1)[1]))
    return None


class Load:
    """The clients and what they measured."""

    def __init__(self, port: int, pause: float) -> None:
        self.port = port
        self.pause = pause
        self.done = asyncio.Event()
        self.get_ms: list[float] = []  # cached GET /axes/x of the current minute
        self.statuses: dict[int, int] = {}
        self.ws_messages = 0
        #: connections the gateway closed or reset under a client (each one reconnects),
        #: with the last reason: a figure of the run, not a reason to end it
        self.lost: dict[str, int] = {"ws": 0, "http": 0}
        self.last_loss = ""

    def _lose(self, kind: str, exc: BaseException) -> None:
        self.lost[kind] += 1
        self.last_loss = f"{time.strftime('%H:%M:%S')} {kind}: {exc!r}"
        print(json.dumps({"lost": self.last_loss}), file=sys.stderr, flush=True)

    async def ws_client(self, n: int) -> None:
        while not self.done.is_set():
            try:
                await self._ws_session()
            except (OSError, ConnectionClosed) as exc:
                self._lose("ws", exc)
                await asyncio.sleep(1.0)

    async def _ws_session(self) -> None:
        async with connect(f"ws://127.0.0.1:{self.port}/api/v1/ws", max_size=None) as ws:
            await ws.send(json.dumps({"type": "subscribe", "topics": TOPICS}))
            while not self.done.is_set():
                try:
                    async with asyncio.timeout(1.0):
                        await ws.recv()
                    self.ws_messages += 1
                except TimeoutError:
                    continue

    async def rest_client(self, n: int) -> None:
        rng = random.Random(n)
        while not self.done.is_set():
            try:
                await self._rest_session(rng)
            except (OSError, asyncio.IncompleteReadError, IndexError, ValueError) as exc:
                self._lose("http", exc)
                await asyncio.sleep(1.0)

    async def _rest_session(self, rng: random.Random) -> None:
        reader, writer = await asyncio.open_connection("127.0.0.1", self.port)
        try:
            while not self.done.is_set():
                method, path, body = self._request(rng)
                began = time.perf_counter()
                status, _ = await exchange(reader, writer, method, path, body)
                if method == "GET" and path == "/api/v1/axes/x":
                    self.get_ms.append((time.perf_counter() - began) * 1000)
                self.statuses[status] = self.statuses.get(status, 0) + 1
                await asyncio.sleep(self.pause)
        finally:
            writer.close()

    def _request(self, rng: random.Random) -> tuple[str, str, Any]:
        axis = rng.choice(AXES)
        pick = rng.random()
        if pick < 0.40:
            return "GET", "/api/v1/axes/x", None
        if pick < 0.50:
            return "GET", f"/api/v1/axes/{axis}?fresh=true", None
        if pick < 0.65:
            body = {"position": rng.randrange(-5000, 5000), "unit": "pulse"}
            return "POST", f"/api/v1/axes/{axis}/move", body
        if pick < 0.72:
            return "PUT", f"/api/v1/axes/{axis}/speed", {"oh": rng.randrange(2000, 4000)}
        if pick < 0.80:
            return "GET", "/api/v1/operations", None
        if pick < 0.86:
            return "POST", f"/api/v1/axes/{axis}/lease", {}
        if pick < 0.92:
            return "DELETE", f"/api/v1/axes/{axis}/lease", None
        if pick < 0.96:
            return "GET", "/api/v1/audit?limit=20", None
        return "POST", f"/api/v1/axes/{axis}/stop", {}


def p(values: list[float], q: float) -> float | None:
    if len(values) < 2:
        return None
    return round(statistics.quantiles(values, n=100, method="inclusive")[round(q) - 1], 2)


def slope_mb_an_hour(samples: list[tuple[float, float]]) -> float | None:
    """Least-squares slope of (minute, MB) samples, in MB an hour."""
    if len(samples) < 3:
        return None
    xs, ys = [s[0] for s in samples], [s[1] for s in samples]
    mx, my = statistics.mean(xs), statistics.mean(ys)
    var = sum((x - mx) ** 2 for x in xs)
    return round(sum((x - mx) * (y - my) for x, y in samples) / var * 60, 2) if var else None


async def soak(args: argparse.Namespace, bench: Bench) -> dict[str, Any]:
    line_port, control_port, http_port = free_port(), free_port(), free_port()
    bench.sim(line_port, "1,2,3", "--control", f"127.0.0.1:{control_port}")
    if args.tracemalloc:
        bench.env["RC233_TRACEMALLOC"] = "1"
        bench.env["RC233_TRACEMALLOC_OUT"] = str(args.heap_out.resolve())
    pid = bench.gateway("soak", line_port, "1,2,3", http_port)
    await wait_ready(http_port, "/api/v1/axes/x", timeout=120)
    for rule in FAULTS:
        reader, writer = await asyncio.open_connection("127.0.0.1", control_port)
        writer.write(json.dumps({"op": "fault", **rule}).encode() + b"\n")
        answer = json.loads(await reader.readline())
        writer.close()
        assert answer.get("ok"), answer
    before = {**process_figures(pid), "tasks": await asyncio_tasks(http_port)}
    if args.tracemalloc:
        dump_heaps(pid)  # the first dump is the start: later ones what grew
    print(json.dumps({"before_clients": before}), flush=True)
    load = Load(http_port, args.pause)
    clients = [asyncio.create_task(load.ws_client(n)) for n in range(args.ws_clients)]
    clients += [asyncio.create_task(load.rest_client(n)) for n in range(args.rest)]
    minutes: list[dict[str, Any]] = []
    start = time.monotonic()
    for minute in range(1, args.minutes + 1):
        await asyncio.sleep(max(0.0, start + minute * 60 - time.monotonic()))
        for task in clients:
            if task.done() and task.exception() is not None:
                raise SystemExit(f"a client failed: {task.exception()!r}")
        times, load.get_ms = load.get_ms, []
        row = {
            "minute": minute,
            **process_figures(pid),
            "tasks": await asyncio_tasks(http_port),
            "get_p50_ms": p(times, 50),
            "get_p99_ms": p(times, 99),
            "answers": dict(sorted(load.statuses.items())),
            "ws_messages": load.ws_messages,
            "connections_lost": dict(load.lost),
        }
        minutes.append(row)
        print(json.dumps(row), flush=True)
        if args.tracemalloc and minute % args.tracemalloc == 0:
            dump_heaps(pid)
    load.done.set()
    await asyncio.gather(*clients)
    # The gateway closes what the clients left within its own time-outs: wait for them.
    after: dict[str, Any] = {}
    until = time.monotonic() + 30
    while time.monotonic() < until:
        after = {**process_figures(pid), "tasks": await asyncio_tasks(http_port)}
        if after["fds"] <= before["fds"] and after["tasks"] == before["tasks"]:
            break
        await asyncio.sleep(1.0)
    warm = [(r["minute"], r["rss_mb"]) for r in minutes if r["minute"] > args.warmup]
    return {
        "minutes": args.minutes,
        "warmup_minutes": args.warmup,
        "ws_clients": args.ws_clients,
        "rest_clients": args.rest,
        "rss_mb_first_minute": minutes[0]["rss_mb"],
        "rss_mb_last_minute": minutes[-1]["rss_mb"],
        "rss_mb_peak": max(r["rss_mb"] for r in minutes),
        "rss_slope_mb_an_hour_after_warmup": slope_mb_an_hour(warm),
        "before_clients": before,
        "after_clients_left": after,
        "get_p99_ms_first_minute": minutes[0]["get_p99_ms"],
        "get_p99_ms_last_minute": minutes[-1]["get_p99_ms"],
        "answers": dict(sorted(load.statuses.items())),
        "ws_messages": load.ws_messages,
        "connections_lost": dict(load.lost),
        "last_connection_lost": load.last_loss,
        "load_average": round(os.getloadavg()[0], 2),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=int, default=120, help="how long the clients stay")
    parser.add_argument("--warmup", type=int, default=30, help="minutes left out of the slope")
    parser.add_argument("--ws-clients", type=int, default=50)
    parser.add_argument("--rest", type=int, default=4, help="HTTP clients (keep-alive)")
    parser.add_argument("--pause", type=float, default=0.4, help="seconds between requests")
    parser.add_argument("--tracemalloc", type=int, default=0, help="heap dump every N minutes")
    parser.add_argument("--heap-out", type=Path, default=Path("soak-heap.txt"))
    parser.add_argument("--python", default=sys.executable, help="the gateway's Python")
    parser.add_argument("--src", type=Path, help="run the gateway from this source tree")
    parser.add_argument("--logs", type=Path, help="keep the processes' logs in this directory")
    args = parser.parse_args()
    if args.minutes < 1 or not 0 <= args.warmup < args.minutes:
        parser.error("--minutes must be >= 1 and --warmup within 0 and --minutes - 1")
    signal.signal(signal.SIGTERM, signal.default_int_handler)  # the processes are closed
    with tempfile.TemporaryDirectory(prefix="soak-") as tmp:
        work = Path(tmp)
        if args.logs is not None:
            args.logs.mkdir(parents=True, exist_ok=True)
            work = args.logs
        bench = Bench(args.src, args.python, work)
        try:
            summary = asyncio.run(soak(args, bench))
        finally:
            bench.close()
    targets = {
        "rss_slope_mb_an_hour_after_warmup": "< 5",
        "get_p99_ms_last_minute": "<= first minute",
        "after_clients_left": "fds and tasks back to before_clients",
    }
    print(json.dumps({"summary": summary, "targets": targets}, indent=2), flush=True)


if __name__ == "__main__":
    main()
