"""Many cells on one broker: broker traffic per moving axis and the lag to a central host.

Starts Debian's mosquitto on a free loopback port and ``--cells`` gateway processes
(``rc233-gateway serve --simulate`` at real time, three controllers each, with an ``[mqtt]``
edge node), moves one axis of every controller to ``--target`` pulses and back, and prints one
JSON object: moving axes, seconds, bytes a second and DDATA a second per moving axis (topic and
payload of every message meanwhile), and the lag from the simulator to the central subscriber
(arrival minus the metric's timestamp, the time the gateway read the position): p50, p99, max.

    .venv/bin/python bench/mqtt_cells.py --cells 3
    .venv/bin/python bench/mqtt_cells.py --cells 8 --target 20000

The helpers are the MQTT tests' (tests/support/mqtt_broker.py): the same broker, processes and
independent Sparkplug decoder.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.support.mqtt_broker import Broker, Cell, Central

MOVING = ("x", "z", "gripper")
DEVICES = {"x": "gantry", "z": "head", "gripper": "handler"}


async def run(cells: int, target: int) -> dict[str, object]:
    work = Path(tempfile.mkdtemp(prefix="rc233-bench-mqtt-"))
    broker = Broker(work)
    await broker.start()
    procs = [Cell(broker.port, f"cell-{i:02d}", time_scale=1.0) for i in range(cells)]
    try:
        async with Central(broker.port) as central:
            for i, cell in enumerate(procs):
                (work / str(i)).mkdir()
                await cell.start(work / str(i))
            for cell in procs:
                for device in DEVICES.values():
                    await central.wait_for(
                        "DDATA", node=cell.node, device=device, timeout=60,
                        where=lambda m: "Mode" in m.values,
                    )  # fmt: skip
            start, began = central.mark(), time.monotonic()
            for position in (target, 0):
                mark = central.mark()
                await asyncio.gather(*(c.move(a, position) for c in procs for a in MOVING))
                for cell in procs:
                    for axis, device in DEVICES.items():
                        name = f"Axis/{axis}/Position"
                        await central.wait_for(
                            "DDATA", node=cell.node, device=device, since=mark, timeout=120,
                            where=lambda m, n=name, p=position: m.values.get(n) == p,
                        )  # fmt: skip
            seconds = time.monotonic() - began
            during = central.messages[start:]
            lags = sorted(
                m.at - metric.timestamp / 1000
                for m in during if m.kind == "DDATA"
                for metric in m.payload.metrics
                if metric.alias is not None and metric.timestamp is not None
                and "/Position" in central.aliases.get((m.node, metric.alias), "")
            )  # fmt: skip
    finally:
        for cell in procs:
            await cell.stop()
        await broker.stop()
    axes = cells * len(MOVING)
    traffic = sum(len(m.topic) + len(m.payload_bytes) for m in during)
    return {
        "cells": cells,
        "moving_axes": axes,
        "seconds": round(seconds, 2),
        "bytes_per_s_per_moving_axis": round(traffic / seconds / axes),
        "ddata_per_s_per_moving_axis": round(
            sum(m.kind == "DDATA" for m in during) / seconds / axes, 1
        ),
        "positions": len(lags),
        "lag_ms": {
            "p50": round(statistics.median(lags) * 1000, 1),
            "p99": round(lags[max(0, int(len(lags) * 0.99) - 1)] * 1000, 1),
            "max": round(lags[-1] * 1000, 1),
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=3)
    parser.add_argument("--target", type=int, default=8000, help="pulses (default 8000)")
    args = parser.parse_args()
    print(json.dumps(asyncio.run(run(args.cells, args.target))))


if __name__ == "__main__":
    main()
