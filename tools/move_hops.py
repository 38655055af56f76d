"""Count the calls a move takes from its route handler to the transport's write.

Runs ``POST /axes/x/move`` against the in-process simulated app of the API tests and records
the gateway's own stack frames at three points: when the operation starts
(``Operations.run``), when the request joins the loop's queue, and when the move's frame
(``$13``) is written. The calls in between are the hops of docs/architecture.md; two task
hand-offs (the operation's send, the loop's task) cut the stack in three.

Then the stop's path: a stop asked for while a transaction of reads is between two frames
(a scheduler on the simulated loop alone), from the loop's task to the stop's write
(``$2SS``). It must stay short: it goes through the stop lane, inside the transaction it
overtakes (DESIGN invariant 8).

    .venv/bin/python tools/move_hops.py
"""

from __future__ import annotations

import asyncio
import sys
import traceback
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).parents[1]))

from gateway.bus import queue
from gateway.bus.config import LoopConfig
from gateway.bus.events import BusEvent, ReplyObserved
from gateway.bus.scheduler import LoopScheduler
from gateway.protocol.command_text import parse
from gateway.protocol.framing import BAUD_RATES
from gateway.service.operations.book import Operations
from gateway.sim.cli import build_loop
from gateway.sim.clock import SimClock
from gateway.sim.faults import Faults
from gateway.sim.memory import Baud
from gateway.sim.serve import SimPort
from gateway.transport import pipe
from tests.support.sim_app import running_app

Stack = list[str]
seen: dict[str, list[Stack]] = {}


def ours() -> Stack:
    """The gateway's frames of the current stack (not the tests', the libraries')."""
    return [
        f"{f.filename.split('/gateway/', 1)[-1]}:{f.name}"
        for f in traceback.extract_stack()[:-2]
        if "/gateway/" in f.filename and "/tests/" not in f.filename
    ]


def record(cls: type, name: str, key: str, when: Any = None) -> None:
    """Note the stack under ``seen[key]`` whenever ``cls.name`` is called (and ``when(*args)``)."""
    real = getattr(cls, name)
    if asyncio.iscoroutinefunction(real):

        async def wrapped_async(self: Any, *args: Any, **kwargs: Any) -> Any:
            seen.setdefault(key, []).append(ours())
            return await real(self, *args, **kwargs)

        setattr(cls, name, wrapped_async)
        return

    def wrapped(self: Any, *args: Any, **kwargs: Any) -> Any:
        if when is None or when(*args):
            seen.setdefault(key, []).append(ours())
        return real(self, *args, **kwargs)

    setattr(cls, name, wrapped)


async def main() -> None:
    """One move through the app; the calls of each part, printed."""
    record(Operations, "run", "start")
    for cls in vars(queue).values():
        if isinstance(cls, type) and cls.__module__ == queue.__name__ and "put" in vars(cls):
            record(cls, "put", "queue")
    for cls in vars(pipe).values():
        if isinstance(cls, type) and "write" in vars(cls):
            record(cls, "write", "write", lambda data: data.startswith(b"$13"))
            record(cls, "write", "stop write", lambda data: data.startswith(b"$2SS"))
    async with running_app() as api:
        seen.clear()
        r = await api.client.post(
            "/axes/x/move", params={"wait": "true"}, json={"position": 12.5, "unit": "user"}
        )
        assert r.status_code == 200, r.text
    start = seen["start"][-1]
    start = start[next(i for i, f in enumerate(start) if "routes/axes" in f) :]
    parts = [
        ("route -> Operations.run", [*start, "Operations.run"]),
        ("operation's task -> queue put", [*seen["queue"][-1], "queue put"]),
        ("loop task -> transport write", [*seen["write"][0], "transport write"]),
    ]
    total = 0
    for title, calls in parts:
        print(f"{title}: {len(calls)}")
        for call in calls:
            print(f"    {call}")
        total += len(calls)
    print(f"calls from the route handler to the write: {total}")
    await stop_between_frames()
    stop = seen["stop write"][0]
    stop = [*stop[next(i for i, f in enumerate(stop) if f.endswith(":_run")) :], "transport write"]
    print(f"a stop between two frames, loop task -> transport write: {len(stop)}")
    for call in stop:
        print(f"    {call}")


async def stop_between_frames() -> None:
    """A stop to controller 2 asked for once a transaction of reads to 1 has had a reply."""
    scale, baud = 100.0, 9600
    sim = build_loop(["1", "2"], clock=SimClock(scale), baud=baud, faults=Faults(seed=1))
    for unit in sim.units:
        unit.device.baud = Baud(BAUD_RATES.index(baud))
    line = pipe.PipeTransport(lambda: SimPort(sim), url="pipe://sim", baud=baud)
    scheduler = LoopScheduler(line, LoopConfig(time_scale=scale, host_latency=0.02))
    stops: list[asyncio.Future[Any]] = []

    def stop_now(event: BusEvent) -> None:
        if isinstance(event, ReplyObserved) and event.command.wire() == "A001D" and not stops:
            stops.append(asyncio.ensure_future(scheduler.stop("2", parse("SS"))))

    scheduler.events.subscribe(stop_now)
    await scheduler.start()
    try:
        await scheduler.submit("1", [parse(f"A{n:03d}D") for n in range(6)])
        await asyncio.gather(*stops)
    finally:
        await scheduler.close()
        sim.close()


if __name__ == "__main__":
    asyncio.run(main())
