"""The gateway measured from outside: a process on a TCP line, HTTP load, stops through REST.

Everything runs as separate processes, the way a site runs them: ``rc233-gateway sim --tcp``
(real time, 9600 bps, 1 ms turnaround), ``rc233-gateway serve --config`` on a generated
configuration (``--no-auth`` on loopback), and between them a proxy (bench/outside_parts.py)
that stamps every chunk of bytes with the machine's monotonic clock. This process is the HTTP
clients. Phases, one after the other:

1. ``line``: ``--callers`` clients keep the scheduler's queue full of reads
   (``POST /loops/main/raw``) over three controllers while a stop is sent through
   ``POST /axes/x/stop`` every 100 ms. From the proxy's record: line efficiency (for every
   exchange its ideal wire time, 10 bits a character, plus 1 ms turnaround, over the elapsed
   time), the simulator's lateness (a reply's last byte against the time the ideal line would
   have delivered it, from the moment the command passed the proxy), the gateway's gap (a
   reply's last byte to the next frame, p50/p99), and the stop latency (request sent to the
   ``S``/``SS`` frame on the wire, p99; over what the exchange in flight still had to run;
   how many other frames went before it).
2. ``watch``: no load; axis x moves; position reads of it on the wire a second (and the
   status reads), against a naive blocking pyserial loop asking ``$16`` on another simulator
   through the same proxy.
3. ``http``: cached ``GET /api/v1/axes/x`` against a bare FastAPI route on the uvicorn
   settings ``serve`` uses, 16 keep-alive connections each; the server's CPU a request.
4. ``idle``: another gateway on a 15-controller loop, nothing asked: its CPU share and the
   exchanges a second its poller makes.
5. ``cli``: wall time of ``rc233-gateway parse OH99999`` (median of 3).

``--src DIR`` runs the gateway and the simulator from another source tree (the figures
"before" a change: ``git archive main | tar -x -C DIR``). It prints one JSON object; each
figure beside its target, with the machine's load average. Fan-out is bench/api.py's.

    .venv/bin/python bench/line_outside.py                   # 10 s a phase
    .venv/bin/python bench/line_outside.py --seconds 2       # what make bench runs
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import re
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from outside_record import Row, analyse_line, analyse_watch

HERE = Path(__file__).resolve().parent
PARTS = str(HERE / "outside_parts.py")
CELL = """
[[loops]]
name = "main"
port = "socket://127.0.0.1:{port}"
{controllers}
"""
CONTROLLER = """
[[loops.controllers]]
body = "{body}"
name = "c{body}"
[[loops.controllers.axes]]
motor = 1
name = "{axis}"
"""
#: The console script, run from the tree on sys.path (--src: another one).
CLI = ("-c", "import sys; from gateway.cli import main; sys.exit(main())")
READS = ["OH", "OL", "CL", "2D", "OX"]
STOP_TEXT = re.compile(r"^\$1SS?\\r$")  # as the trace writes it: CR escaped


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


class Bench:
    """The processes of a run and what they need."""

    def __init__(self, src: Path | None, python: str, tmp: Path) -> None:
        self.tmp = tmp
        self.python = python  # of the gateway, the simulator and the bare app
        # Its own data and state directories: a gateway running beside the benchmark holds
        # the user's state directory (one gateway per state directory).
        self.env = {**os.environ, "XDG_DATA_HOME": str(tmp), "XDG_STATE_HOME": str(tmp)}
        if src is not None:
            self.env["PYTHONPATH"] = str(src)
        self.procs: list[subprocess.Popen[bytes]] = []

    def start(self, *argv: str, ready: str | None = None, log: str = "") -> subprocess.Popen[bytes]:
        err = open(self.tmp / f"{log or argv[1]}.log", "ab")  # noqa: SIM115
        # cwd: the temporary directory, so that `python -c` finds the gateway of --src or
        # --python, not the one of the directory the benchmark was started in.
        proc = subprocess.Popen(
            [self.python, *argv], stdout=subprocess.PIPE, stderr=err, env=self.env, cwd=self.tmp
        )
        self.procs.append(proc)
        if ready is not None:
            assert proc.stdout is not None
            line = proc.stdout.readline().decode()
            if ready not in line:
                raise SystemExit(f"{argv}: {line or 'ended'} (see {err.name})")
        return proc

    def sim(self, port: int, bodies: str, *options: str) -> None:
        self.start(
            *CLI, "sim", "--tcp", f"127.0.0.1:{port}", "--bodies", bodies, *options,
            "--eeprom-dir", str(self.tmp / f"eeprom{port}"), ready="listening", log=f"sim{port}",
        )  # fmt: skip

    def gateway(self, name: str, line_port: int, bodies: str, http_port: int) -> int:
        controllers = "".join(
            CONTROLLER.format(body=b, axis="x" if b == "1" else f"a{b}") for b in bodies.split(",")
        )
        cell = self.tmp / f"{name}.toml"
        cell.write_text(CELL.format(port=line_port, controllers=controllers))
        proc = self.start(
            *CLI, "serve", "--config", str(cell), "--no-auth",
            "--port", str(http_port), ready="rc233-gateway serve", log=name,
        )  # fmt: skip
        return proc.pid

    def stop(self, proc: subprocess.Popen[bytes]) -> None:
        proc.send_signal(signal.SIGINT if proc.args[1:3] == list(CLI) else signal.SIGTERM)  # type: ignore[index]
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()

    def close(self) -> None:
        for proc in reversed(self.procs):
            if proc.poll() is None:
                self.stop(proc)


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def descendants(pid: int) -> list[int]:
    """``pid`` and every process below it (``/proc``'s parent links)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, IndexError, ValueError):
            continue  # gone meanwhile
        children.setdefault(ppid, []).append(int(entry.name))
    found, todo = [], [pid]
    while todo:
        current = todo.pop()
        found.append(current)
        todo += children.get(current, [])
    return found


def tree_cpu(pid: int) -> tuple[float, int]:
    """CPU seconds of ``pid`` and its descendants, and how many processes that is. A child
    that ended meanwhile is not counted: read it over windows where none ends."""
    total, count = 0.0, 0
    for each in descendants(pid):
        try:
            total += cpu_seconds(each)
            count += 1
        except OSError:
            pass
    return total, count


async def http(port: int, method: str, path: str, body: Any = None) -> tuple[int, bytes]:
    """One request on its own connection: status and body."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        return await _exchange(reader, writer, method, path, body)
    finally:
        writer.close()


async def _exchange(
    reader: asyncio.StreamReader, writer: asyncio.StreamWriter, method: str, path: str, body: Any
) -> tuple[int, bytes]:
    """One request on a keep-alive connection; every request that acts is declared JSON,
    bodyless too (the gateway refuses it otherwise: 415)."""
    data = b"" if body is None else json.dumps(body).encode()
    head = f"{method} {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: {len(data)}\r\n"
    if method != "GET":
        head += "Content-Type: application/json\r\n"
    writer.write(head.encode() + b"\r\n" + data)
    status = int((await reader.readline()).split()[1])
    length = 0
    while (line := await reader.readline()) not in (b"\r\n", b""):
        if line.lower().startswith(b"content-length:"):
            length = int(line[15:])
    return status, await reader.readexactly(length)


async def wait_ready(port: int, path: str, timeout: float = 60) -> None:
    until = time.monotonic() + timeout
    while time.monotonic() < until:
        try:
            status, body = await http(port, "GET", path)
            if status == 200 and b'"position":null' not in body.replace(b" ", b""):
                return
        except OSError:
            pass
        await asyncio.sleep(0.2)
    raise SystemExit(f"the gateway on {port} never answered {path}")


async def line_phase(port: int, seconds: float, callers: int) -> tuple[list[float], float, float]:
    """Phase 1: the queue kept full, stops sent; the stops' send times and the window."""
    done = asyncio.Event()

    async def caller(n: int) -> None:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        i = n
        while not done.is_set():
            body = {"controller": str(1 + i % 3), "text": READS[i % len(READS)]}
            await _exchange(reader, writer, "POST", "/api/v1/loops/main/raw", body)
            i += 1
        writer.close()

    tasks = [asyncio.create_task(caller(n)) for n in range(callers)]
    # The gateway's line trace notes when each stop is queued, among the frames it writes.
    trace = {"enabled": True, "clear": True}
    status, text = await http(port, "PUT", "/api/v1/loops/main/trace", trace)
    assert status == 200, text
    await asyncio.sleep(0.5)
    start, sent = time.monotonic(), []
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    while time.monotonic() - start < seconds:
        sent.append(time.monotonic())
        status, text = await _exchange(reader, writer, "POST", "/api/v1/axes/x/stop", {})
        assert status == 200, text
        await asyncio.sleep(0.1)
    end = time.monotonic()
    writer.close()
    done.set()
    await asyncio.gather(*tasks)
    return sent, start, end


def stops_queued(trace: tuple[int, bytes], rows: list[Row]) -> list[float] | None:
    """When the gateway queued each stop, on the proxy's clock. None: a gateway that does
    not note them.

    The trace's times are wall-clock; they are put on the proxy's monotonic clock by the
    frames both saw: the median of (proxy time - trace time) over the traced frames, so a
    wall clock slewed since the gateway started does not move the marks.
    """
    status, text = trace
    if status != 200:
        return None
    lines = json.loads(text)["lines"]
    notes = [line["time"] for line in lines if line["note"] == "stop queued"]
    if not notes:
        return None
    seen: dict[str, list[float]] = {}
    for when, name, way, data in rows:
        if name == "main" and way == "h2d":
            seen.setdefault(data, []).append(when)
    rough = time.time() - time.monotonic()
    shifts = []
    for line in lines:
        if line["direction"] != "tx":
            continue
        guess = line["time"] - rough
        near = min(seen.get(line["text"].replace("\\r", "\r"), []), default=None,
                   key=lambda t: abs(t - guess))  # fmt: skip
        if near is not None and abs(near - guess) < 0.05:
            shifts.append(near - line["time"])
    shift = statistics.median(shifts) if shifts else -rough
    return [note + shift for note in notes]


def frames_before_stops(trace: tuple[int, bytes]) -> int:
    """Stops with another frame written between their queueing and their own frame, in the
    order the gateway's own trace has them (no clocks compared)."""
    lines = json.loads(trace[1])["lines"]
    behind, waiting = 0, False
    for line in lines:
        if line["note"] == "stop queued":
            waiting = True
        elif line["direction"] == "tx" and waiting:
            if STOP_TEXT.match(line["text"]):
                waiting = False
            else:
                behind += 1
                waiting = False
    return behind


async def sim_lateness(port: int) -> dict[str, Any]:
    """The simulator's own record of how late it handed each reply over (its ``trace``):
    what the proxy's figure holds beside the proxy's own delays. Older simulators keep none."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port, limit=1 << 26)
    writer.write(b'{"op": "trace"}\n')
    reply = json.loads(await reader.readline())
    writer.close()
    late = [r["late"] for r in reply.get("trace", []) if r["kind"] == "reply" and "late" in r]
    if not late:
        return {"sim_own_late_ms_median": None, "sim_own_late_ms_p99": None}
    ordered = sorted(late)
    return {
        "sim_own_late_ms_median": round(statistics.median(late) * 1000, 3),
        "sim_own_late_ms_p99": round(ordered[int(0.99 * (len(ordered) - 1))] * 1000, 3),
    }


def run_part(*argv: str) -> dict[str, Any]:
    out = subprocess.run([sys.executable, PARTS, *argv], capture_output=True, check=True)
    result: dict[str, Any] = json.loads(out.stdout.decode().strip().splitlines()[-1])
    return result


def http_rate(port: int, path: str, pid: int, seconds: float) -> dict[str, float]:
    before = cpu_seconds(pid)
    rate = run_part("load", "--port", str(port), "--path", path, "--seconds", str(seconds))
    cpu = cpu_seconds(pid) - before
    return {
        "rps": round(rate["per_second"]),
        "server_cpu_ms_per_request": round(cpu / rate["requests"] * 1000, 3),
    }


def parse_start(bench: Bench) -> float:
    times = []
    for _ in range(3):
        start = time.monotonic()
        subprocess.run(
            [bench.python, *CLI, "parse", "OH99999"],
            env=bench.env, cwd=bench.tmp, capture_output=True, check=False,
        )  # fmt: skip
        times.append(time.monotonic() - start)
    return statistics.median(times)


async def run(args: argparse.Namespace, bench: Bench) -> dict[str, Any]:
    load = [round(x, 2) for x in os.getloadavg()]
    ports = {
        name: free_port()
        for name in ("sim", "control", "naive", "sim15", "p", "pn", "p15", "h", "h15", "bare")
    }
    bench.sim(ports["sim"], "1,2,3", "--control", f"127.0.0.1:{ports['control']}")
    bench.sim(ports["naive"], "1")
    bodies15 = ",".join("0123456789ABCDE")
    bench.sim(ports["sim15"], bodies15)
    record = bench.tmp / "line.jsonl"
    proxy = bench.start(
        PARTS, "proxy", "--out", str(record),
        "--pair", f"main:{ports['p']}:{ports['sim']}",
        "--pair", f"naive:{ports['pn']}:{ports['naive']}",
        "--pair", f"idle:{ports['p15']}:{ports['sim15']}",
        ready="ready", log="proxy",
    )  # fmt: skip
    pid = bench.gateway("gateway", ports["p"], "1,2,3", ports["h"])
    await wait_ready(ports["h"], "/api/v1/axes/x")
    sent, start, end = await line_phase(ports["h"], args.seconds, args.callers)
    trace = await http(ports["h"], "GET", "/api/v1/loops/main/trace")
    own_late = await sim_lateness(ports["control"])
    # Phase 2: one watched axis moving, nothing else asked. ``--watch-settle``: first let the
    # poller finish what the line phase held back (the first reads of controllers the load
    # starved), and let the plan settle into its watched rhythm after the move starts.
    await asyncio.sleep(args.watch_settle)
    move = {"position": 2_000_000, "relative": True, "unit": "pulse"}
    status, text = await http(ports["h"], "POST", "/api/v1/axes/x/move", move)
    assert status == 202, text
    await asyncio.sleep(max(0.3, args.watch_settle))
    watch = (time.monotonic(), time.monotonic() + args.seconds)
    await asyncio.sleep(args.seconds)
    await http(ports["h"], "POST", "/api/v1/axes/x/stop", {})
    naive = run_part(
        "naive", "--url", f"socket://127.0.0.1:{ports['pn']}", "--move", "$122000000\r",
        "--move", "$14\r", "--seconds", str(args.seconds),
    )  # fmt: skip
    naive_window = (naive["start"], naive["end"])
    # Phase 3: cached reads against a bare route.
    axes = http_rate(ports["h"], "/api/v1/axes/x", pid, args.seconds)
    bare_proc = bench.start(PARTS, "bare", "--port", str(ports["bare"]), ready="ready", log="bare")
    await wait_ready(ports["bare"], "/api/v1/bare")
    bare = http_rate(ports["bare"], "/api/v1/bare", bare_proc.pid, args.seconds)
    bench.stop(bare_proc)
    bench.stop(next(p for p in bench.procs if p.pid == pid))
    # Phase 4: an idle gateway on 15 controllers.
    pid15 = bench.gateway("gateway15", ports["p15"], bodies15, ports["h15"])
    await wait_ready(ports["h15"], "/api/v1/axes/x")
    await asyncio.sleep(2.0)
    # Every process of the gateway (line workers are children of serve).
    idle = (time.monotonic(), tree_cpu(pid15)[0])
    await asyncio.sleep(args.seconds)
    idle_end = (time.monotonic(), tree_cpu(pid15)[0])
    cli = parse_start(bench)
    bench.stop(proxy)
    rows = [json.loads(line) for line in record.read_text().splitlines()]
    queued = stops_queued(trace, rows)
    line = analyse_line(rows, "main", start, end, sent, queued)
    if queued is not None:
        line["stops_behind_another_frame_in_the_gateway_trace"] = frames_before_stops(trace)
    watched = analyse_watch(rows, "main", *watch)
    naive_frames = analyse_watch(rows, "naive", *naive_window)
    idle_frames = [
        r for r in rows if r[1] == "idle" and r[2] == "h2d" and idle[0] <= r[0] <= idle_end[0]
    ]
    idle_seconds = idle_end[0] - idle[0]
    idle_cpu = idle_end[1] - idle[1]
    position_rate = watched["position_reads_per_s"]
    return {
        "load_average_before": load,
        "load_average_after": [round(x, 2) for x in os.getloadavg()],
        "seconds_a_phase": args.seconds,
        "line": {**line, **own_late},
        "watched_axis": {
            **watched,
            "naive_pyserial_per_s": round(naive["per_second"], 1),
            "naive_on_the_wire_per_s": naive_frames["position_reads_per_s"],
            "naive_axis_moved": naive["moved"],
            "ratio": round(position_rate / naive["per_second"], 3),
            "target": ">= 0.92 with status >= 5/s",
        },
        "cached_get": {
            "axes": axes,
            "bare": bare,
            "ratio": round(axes["rps"] / bare["rps"], 3),
            "target": ">= 0.8",
        },
        "idle_15_controllers": {
            "cpu_percent": round(idle_cpu / idle_seconds * 100, 2),
            "exchanges_per_s": round(len(idle_frames) / idle_seconds, 1),
            "cpu_ms_per_exchange": round(idle_cpu / max(1, len(idle_frames)) * 1000, 3),
            "target": "<= 1.0 %, <= 0.2 ms an exchange, all the gateway's processes",
        },
        "cli_parse_seconds": {"median_of_3": round(cli, 3), "target": "<= 0.5"},
        "fan_out": "bench/api.py",
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="seconds a phase")
    parser.add_argument("--callers", type=int, default=12, help="HTTP clients in phase 1")
    parser.add_argument("--src", type=Path, help="run the gateway from this source tree")
    parser.add_argument(
        "--watch-settle",
        type=float,
        default=0.0,
        help="seconds waited before the watched move and before its window (0: at once; "
        "the steady state of a watched axis: 3)",
    )
    parser.add_argument(
        "--python",
        default=sys.executable,
        help="the Python (of a virtual environment) that runs the gateway, the simulator and "
        "the bare app: another installation, with its own uvicorn, for figures before a change",
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="line-outside-") as tmp:
        bench = Bench(args.src, args.python, Path(tmp))
        try:
            figures = asyncio.run(run(args, bench))
        finally:
            bench.close()
            if os.environ.get("KEEP_LOGS"):
                subprocess.run(["cp", "-r", tmp, os.environ["KEEP_LOGS"]], check=False)
    print(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
