"""600 monitored OPC UA items: the notification lag and the gateway's CPU.

Starts ``rc233-gateway serve --simulate`` (real time unless ``--time-scale``) on ``--loops``
loops of 15 controllers (two axes each) with an ``[opcua]`` section, subscribes with asyncua's
client to every axis value (7 a axis: 630 items for 3 loops) at ``--sampling`` ms, moves one
axis of every controller to ``--target`` pulses and back through the ``MoveAbsolute`` method,
and prints one JSON object: items, notifications, the lag of position notifications (arrival
minus SourceTimestamp, the time the gateway read the position): p50, p99, max, and the serve
process's CPU (seconds of CPU a second) while subscribed and moving.

    .venv/bin/python bench/opcua_items.py --loops 3
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

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from asyncua import Client, ua

from tests.serve_process import free_port, serve

BODIES = "0123456789ABCDE"
VALUES = ("ActualPosition", "ActualPositionPulses", "TargetPosition", "Moving", "LimitError",
          "EmergencyError", "CommandError")  # fmt: skip
TOKEN = "bench-operator-token-0123"
MAX_PER_PUBLISH = int(os.environ.get("MAX_PER_PUBLISH", "0"))


def config(workdir: Path, loops: int, port: int) -> str:
    text = f'state_dir = "{workdir / "state"}"\n'
    for i in range(loops):
        text += f'[[loops]]\nname = "l{i}"\nport = "/dev/null"\n'
        for body in BODIES:
            text += f'[[loops.controllers]]\nbody = "{body}"\n'
            text += "[[loops.controllers.axes]]\nmotor = 1\n[[loops.controllers.axes]]\nmotor = 2\n"
    digest = hashlib.sha256(TOKEN.encode()).hexdigest()
    text += f'[[security.tokens]]\nname = "op"\nrole = "operator"\nsha256 = "{digest}"\n'
    text += f'[opcua]\nendpoint = "opc.tcp://127.0.0.1:{port}"\nsecurity_policies = ["None"]\n'
    return text


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Lags:
    def __init__(self) -> None:
        self.lags: list[float] = []
        self.count = 0
        self.positions: dict[str, Any] = {}

    def status_change_notification(self, status: Any) -> None:
        print(f"subscription status: {status}", file=sys.stderr)

    def datachange_notification(self, node: Any, val: Any, data: Any) -> None:
        self.count += 1
        value = data.monitored_item.Value
        name = node.nodeid.Identifier
        if name.endswith("/ActualPositionPulses") and value.SourceTimestamp is not None:
            self.positions[name] = val
            self.lags.append(time.time() - value.SourceTimestamp.timestamp())


async def run(loops: int, target: int, sampling: float, time_scale: float) -> dict[str, Any]:
    work = Path(tempfile.mkdtemp(prefix="rc233-bench-opcua-"))
    port = free_port()
    (work / "cell.toml").write_text(config(work, loops, port))
    logging.getLogger("asyncua").setLevel(logging.ERROR)
    argv = ("--simulate", "--config", str(work / "cell.toml"), "--time-scale", str(time_scale))
    async with serve(work, *argv) as served:
        try:
            return await _measure(served, port, loops, target, sampling)
        except Exception:
            print("".join(served.log[-40:]), file=sys.stderr)
            raise


async def _measure(served: Any, port: int, loops: int, target: int,
                   sampling: float) -> dict[str, Any]:  # fmt: skip
    if True:
        client = Client(f"opc.tcp://127.0.0.1:{port}", timeout=30)
        client.set_user("op")
        client.set_password(TOKEN)
        async with client:
            axes = [f"l{i}.{b}.{m}" for i in range(loops) for b in BODIES for m in (1, 2)]
            nodes = [client.get_node(f"ns=2;s={a}/{v}") for a in axes for v in VALUES]
            lags = Lags()
            params = ua.CreateSubscriptionParameters(
                RequestedPublishingInterval=sampling, RequestedLifetimeCount=10_000,
                RequestedMaxKeepAliveCount=100, MaxNotificationsPerPublish=MAX_PER_PUBLISH,
                PublishingEnabled=True, Priority=0,
            )  # fmt: skip
            sub = await client.create_subscription(params, lags)
            for i in range(0, len(nodes), 200):
                await sub.subscribe_data_change(nodes[i : i + 200], sampling_interval=sampling)
            moving = [a for a in axes if a.endswith(".1")]
            lags.lags.clear()
            began, cpu0 = time.monotonic(), cpu_seconds(served.pid)
            for position in (target, 0):
                await asyncio.gather(*(
                    client.get_node(f"ns=2;s={a}").call_method("2:MoveAbsolute",
                        ua.Variant(float(position), ua.VariantType.Double), "pulse")
                    for a in moving
                ))  # fmt: skip
                deadline = time.monotonic() + 120
                while time.monotonic() < deadline and any(
                    lags.positions.get(f"{a}/ActualPositionPulses") != position for a in moving
                ):
                    await asyncio.sleep(0.1)  # a bench's progress check, not a test's sync
            seconds = time.monotonic() - began
            cpu = cpu_seconds(served.pid) - cpu0
            await sub.delete()
    q = statistics.quantiles(lags.lags, n=100) if len(lags.lags) > 1 else [0.0] * 99
    return {
        "items": len(nodes), "moving_axes": len(moving), "seconds": round(seconds, 2),
        "notifications": lags.count, "position_notifications": len(lags.lags),
        "lag_ms": {"p50": round(q[49] * 1000, 1), "p99": round(q[98] * 1000, 1),
                   "max": round(max(lags.lags, default=0) * 1000, 1)},
        "serve_cpu_per_s": round(cpu / seconds, 3),
    }  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--loops", type=int, default=3)
    parser.add_argument("--target", type=int, default=4000)
    parser.add_argument("--sampling", type=float, default=100.0, help="ms")
    parser.add_argument("--time-scale", type=float, default=1.0)
    args = parser.parse_args()
    result = asyncio.run(run(args.loops, args.target, args.sampling, args.time_scale))
    print(json.dumps(result))


if __name__ == "__main__":
    main()
