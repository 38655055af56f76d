"""600 monitored OPC UA items: the notification lag, the gateway's CPU, and the line's
efficiency with and without OPC UA clients.

Every part is a process of its own, as on a site: one ``rc233-gateway sim --tcp`` a loop (15
controllers of two axes, real time, 9600 bps), ``rc233-gateway serve --config`` on them with an
``[opcua]`` section (the API process: REST, the OPC UA server and the loops' schedulers), and,
between the gateway and the first loop's simulator, the stamping proxy of
``bench/outside_parts.py``. This process is the clients. Phases:

1. ``items``: asyncua's client subscribes to every axis value (7 an axis: 630 items for 3
   loops) at ``--sampling`` ms on one session, moves one axis of every controller to
   ``--target`` pulses and back through ``MoveAbsolute`` (all calls sent at once), and
   measures the lag of the position notifications (arrival minus SourceTimestamp, the time
   the gateway read the position: p50, p99, max) and the CPU of the gateway process (seconds
   of CPU a second) and of the simulators, while subscribed and moving.
2. ``efficiency``: line efficiency of the first loop as ``bench/line_outside.py`` measures it
   (Σ ideal wire time of frame and reply / elapsed, from the proxy's record), with its queue
   kept full by ``--callers`` HTTP clients reading controllers 0-2 (``POST .../raw``) while
   motor 1 of every other controller of every loop moves (REST), so that positions change
   at every poll. Windows of ``--seconds`` alternate: no OPC UA client, then ``--clients``
   sessions each subscribed to every axis value; the ratio with / without is of one run.

Prints one JSON object with the load average before and after. ``--src DIR`` runs the
gateway and the simulators from another source tree (``git archive main | tar -x -C DIR``).

    .venv/bin/python bench/opcua_items.py --loops 3
    .venv/bin/python bench/opcua_items.py --loops 3 --phase efficiency --rounds 3
"""

from __future__ import annotations

import argparse
import asyncio
import hashlib
import json
import logging
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from asyncua import Client, ua  # noqa: E402
from line_outside import CLI, PARTS, Bench, cpu_seconds, free_port, http, tree_cpu  # noqa: E402
from outside_record import analyse_line  # noqa: E402

BODIES = "0123456789ABCDE"
VALUES = ("ActualPosition", "ActualPositionPulses", "TargetPosition", "Moving", "LimitError",
          "EmergencyError", "CommandError")  # fmt: skip
TOKEN = "bench-operator-token-0123"
READS = ["OH", "OL", "CL", "2D", "OX"]
#: Controllers of the first loop whose queue the HTTP clients keep full (the others move).
READ_BODIES = "012"


def config(loops: int, line_ports: list[int], opc_port: int, state: Path) -> str:
    text = f'state_dir = "{state}"\n'
    for i in range(loops):
        text += f'[[loops]]\nname = "l{i}"\nport = "socket://127.0.0.1:{line_ports[i]}"\n'
        for body in BODIES:
            text += f'[[loops.controllers]]\nbody = "{body}"\n'
            text += "[[loops.controllers.axes]]\nmotor = 1\n[[loops.controllers.axes]]\nmotor = 2\n"
    digest = hashlib.sha256(TOKEN.encode()).hexdigest()
    text += f'[[security.tokens]]\nname = "op"\nrole = "operator"\nsha256 = "{digest}"\n'
    text += f'[opcua]\nendpoint = "opc.tcp://127.0.0.1:{opc_port}"\nsecurity_policies = ["None"]\n'
    return text


class Lags:
    """What the subscription delivered: every notification, the position changes' lag.

    An item's first notification is its value when it was subscribed, stamped with the time
    that value last changed (OPC 10000-4 §7.7.3: the source time of the last change), which
    may be seconds old for an axis at rest: its age is not a delivery lag and is left out."""

    def __init__(self) -> None:
        self.lags: list[float] = []
        self.count = 0
        self.positions: dict[str, Any] = {}
        self.lost: list[str] = []
        self.first: set[str] = set()

    def status_change_notification(self, status: Any) -> None:
        self.lost.append(str(status.Status))
        print(f"subscription status: {status.Status}", file=sys.stderr)

    def datachange_notification(self, node: Any, val: Any, data: Any) -> None:
        self.count += 1
        value = data.monitored_item.Value
        name = node.nodeid.Identifier
        if name not in self.first:
            self.first.add(name)
            self.positions[name] = val
            return
        if name.endswith("/ActualPositionPulses") and value.SourceTimestamp is not None:
            self.positions[name] = val
            self.lags.append(time.time() - value.SourceTimestamp.timestamp())


def _client(port: int) -> Client:
    client = Client(f"opc.tcp://127.0.0.1:{port}", timeout=30)
    client.set_user("op")
    client.set_password(TOKEN)
    return client


async def _subscribe(client: Client, axes: list[str], sampling: float, lags: Lags) -> Any:
    nodes = [client.get_node(f"ns=2;s={a}/{v}") for a in axes for v in VALUES]
    params = ua.CreateSubscriptionParameters(
        RequestedPublishingInterval=sampling, RequestedLifetimeCount=10_000,
        RequestedMaxKeepAliveCount=100, MaxNotificationsPerPublish=0,
        PublishingEnabled=True, Priority=0,
    )  # fmt: skip
    sub = await client.create_subscription(params, lags)
    for i in range(0, len(nodes), 200):
        await sub.subscribe_data_change(nodes[i : i + 200], sampling_interval=sampling)
    return sub


def _quantiles(values: list[float]) -> dict[str, float]:
    q = statistics.quantiles(values, n=100) if len(values) > 1 else [0.0] * 99
    return {"p50": round(q[49] * 1000, 1), "p99": round(q[98] * 1000, 1),
            "max": round(max(values, default=0) * 1000, 1)}  # fmt: skip


async def items_phase(gateway: int, sims: list[int], port: int, axes: list[str],
                      target: int, sampling: float) -> dict[str, Any]:  # fmt: skip
    """Phase 1: every axis value subscribed, one axis of each controller there and back."""
    lags = Lags()
    async with _client(port) as client:
        sub = await _subscribe(client, axes, sampling, lags)
        moving = [a for a in axes if a.endswith(".1")]
        lags.lags.clear()
        began = time.monotonic()
        cpu0, sim0 = cpu_seconds(gateway), sum(cpu_seconds(s) for s in sims)
        calls: list[float] = []
        for position in (target, 0):
            sent = time.monotonic()
            try:
                await asyncio.gather(*(
                    client.get_node(f"ns=2;s={a}").call_method("2:MoveAbsolute",
                        ua.Variant(float(position), ua.VariantType.Double), "pulse")
                    for a in moving
                ))  # fmt: skip
            except ConnectionError as exc:  # the session lost: what the figures are then
                return {"items": len(axes) * len(VALUES), "error": repr(exc),
                        "after_s": round(time.monotonic() - began, 2),
                        "subscription_lost": lags.lost}  # fmt: skip
            calls.append(time.monotonic() - sent)
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and any(
                lags.positions.get(f"{a}/ActualPositionPulses") != position for a in moving
            ):
                await asyncio.sleep(0.1)  # a bench's progress check, not a test's sync
        seconds = time.monotonic() - began
        cpu, sim = cpu_seconds(gateway) - cpu0, sum(cpu_seconds(s) for s in sims) - sim0
        await sub.delete()
    return {
        "items": len(axes) * len(VALUES), "moving_axes": len(moving),
        "seconds": round(seconds, 2), "notifications": lags.count,
        "position_notifications": len(lags.lags), "lag_ms": _quantiles(lags.lags),
        "calls_answered_s": [round(c, 2) for c in calls],
        "subscription_lost": lags.lost,
        "gateway_cpu_per_s": round(cpu / seconds, 3),
        "simulators_cpu_per_s": round(sim / seconds, 3),
    }  # fmt: skip


async def _callers(port: int, done: asyncio.Event, count: int) -> None:
    from line_outside import _exchange

    async def caller(n: int) -> None:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        i = n
        while not done.is_set():
            body = {"controller": READ_BODIES[i % len(READ_BODIES)], "text": READS[i % len(READS)]}
            await _exchange(reader, writer, "POST", "/api/v1/loops/l0/raw", body)
            i += 1
        writer.close()

    await asyncio.gather(*(caller(n) for n in range(count)))


async def efficiency_phase(bench: Bench, proxy: Any, record: Path, gateway: int, port: int,
                           http_port: int, loops: int, args: argparse.Namespace,
                           ) -> dict[str, Any]:  # fmt: skip
    """Phase 2: the first loop's efficiency, windows without and with OPC UA clients."""
    axes = [f"l{i}.{b}.{m}" for i in range(loops) for b in BODIES for m in (1, 2)]
    movers = [a for a in axes if a.endswith(".1") and not (a.startswith("l0.")
              and a.split(".")[1] in READ_BODIES)]  # fmt: skip
    move = {"position": 2_000_000, "relative": True, "unit": "pulse"}
    for axis in movers:
        status, text = await http(http_port, "POST", f"/api/v1/axes/{axis}/move", move)
        assert status == 202, (axis, text)
    done = asyncio.Event()
    callers = asyncio.create_task(_callers(http_port, done, args.callers))
    await asyncio.sleep(1.0)
    windows: list[tuple[str, float, float, float, float]] = []
    for _ in range(args.rounds):
        for mode in ("without", "with"):
            clients: list[Client] = []
            seen: list[Lags] = []
            if mode == "with":
                for _ in range(args.clients):
                    client = _client(port)
                    await client.connect()
                    seen.append(Lags())
                    await _subscribe(client, axes, args.sampling, seen[-1])
                    clients.append(client)
                await asyncio.sleep(1.0)  # the first notifications of every item: settled
            start, cpu0 = time.monotonic(), cpu_seconds(gateway)
            counted = sum(s.count for s in seen)
            await asyncio.sleep(args.seconds)
            end, cpu = time.monotonic(), cpu_seconds(gateway) - cpu0
            rate = (sum(s.count for s in seen) - counted) / (end - start)
            windows.append((mode, start, end, cpu / (end - start), rate))
            for client in clients:
                await client.disconnect()
    done.set()
    await callers
    for i in range(loops):
        await http(http_port, "POST", f"/api/v1/loops/l{i}/stop", {})
    bench.stop(proxy)
    rows = [json.loads(line) for line in record.read_text().splitlines()]
    out: list[dict[str, Any]] = []
    for mode, start, end, cpu, rate in windows:
        line = analyse_line(rows, "main", start, end, [])
        out.append({"opcua_clients": args.clients if mode == "with" else 0,
                    "line_efficiency": line["line_efficiency"],
                    "exchanges": line["exchanges"],
                    "gateway_gap_ms_p50": line["gateway_gap_ms_p50"],
                    "gateway_gap_ms_p99": line["gateway_gap_ms_p99"],
                    "gateway_cpu_per_s": round(cpu, 3),
                    "notifications_per_s": round(rate, 1)})  # fmt: skip
    with_ = [w["line_efficiency"] for w in out if w["opcua_clients"]]
    without = [w["line_efficiency"] for w in out if not w["opcua_clients"]]
    return {
        "windows": out,
        "items_a_client": len(axes) * len(VALUES),
        "efficiency_without_mean": round(statistics.mean(without), 4),
        "efficiency_with_mean": round(statistics.mean(with_), 4),
        "ratio_with_over_without": round(statistics.mean(with_) / statistics.mean(without), 4),
        "target": "the ratio >= 1 within the run's noise (the line does not lose to OPC UA)",
    }


async def _wait_ready(http_port: int, loops: int) -> None:
    until = time.monotonic() + 120
    for i in range(loops):
        while True:
            try:
                status, body = await http(http_port, "GET", f"/api/v1/axes/l{i}.E.2")
                if status == 200 and b'"position":null' not in body.replace(b" ", b""):
                    break
            except OSError:
                pass
            if time.monotonic() > until:
                raise SystemExit(f"loop l{i} never came up")
            await asyncio.sleep(0.3)


async def run(args: argparse.Namespace) -> dict[str, Any]:
    load = [round(x, 2) for x in os.getloadavg()]
    tmp = Path(tempfile.mkdtemp(prefix="rc233-bench-opcua-"))
    bench = Bench(args.src, sys.executable, tmp)
    logging.getLogger("asyncua").setLevel(logging.ERROR)
    try:
        sims = [free_port() for _ in range(args.loops)]
        for port in sims:
            bench.sim(port, ",".join(BODIES))
        sim_pids = [p.pid for p in bench.procs]
        proxied, opc_port, http_port = free_port(), free_port(), free_port()
        record = tmp / "line.jsonl"
        pair = f"main:{proxied}:{sims[0]}"
        proxy = bench.start(PARTS, "proxy", "--out", str(record), "--pair", pair,
                            ready="ready", log="proxy")  # fmt: skip
        cell = tmp / "cell.toml"
        cell.write_text(config(args.loops, [proxied, *sims[1:]], opc_port, tmp / "state"))
        gateway = bench.start(*CLI, "serve", "--config", str(cell), "--no-auth",
                              "--port", str(http_port), ready="rc233-gateway serve",
                              log="gateway").pid  # fmt: skip
        await _wait_ready(http_port, args.loops)
        axes = [f"l{i}.{b}.{m}" for i in range(args.loops) for b in BODIES for m in (1, 2)]
        result: dict[str, Any] = {"load_average_before": load, "loops": args.loops}
        if args.phase in ("items", "all"):
            result["items"] = await items_phase(gateway, sim_pids, opc_port, axes,
                                                args.target, args.sampling)  # fmt: skip
        if args.phase in ("efficiency", "all"):
            result["efficiency"] = await efficiency_phase(
                bench, proxy, record, gateway, opc_port, http_port, args.loops, args
            )
        result["gateway_processes"] = tree_cpu(gateway)[1]
        result["load_average_after"] = [round(x, 2) for x in os.getloadavg()]
        return result
    finally:
        bench.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--loops", type=int, default=3)
    parser.add_argument("--phase", choices=("items", "efficiency", "all"), default="items")
    parser.add_argument("--target", type=int, default=4000)
    parser.add_argument("--sampling", type=float, default=100.0, help="ms")
    parser.add_argument("--seconds", type=float, default=10.0, help="an efficiency window")
    parser.add_argument("--rounds", type=int, default=2, help="pairs of efficiency windows")
    parser.add_argument("--clients", type=int, default=1, help="OPC UA sessions, efficiency")
    parser.add_argument("--callers", type=int, default=12, help="HTTP clients, efficiency")
    parser.add_argument("--src", type=Path, help="run the gateway and simulators from this tree")
    args = parser.parse_args()
    print(json.dumps(asyncio.run(run(args))))


if __name__ == "__main__":
    main()
