"""Lab figures for one design question: the line's driver on the event loop that serves HTTP,
or in a thread of its own with its own event loop.

A peer process answers every frame (``$1\\r`` -> ``>\\r``) after 1 ms and stamps, with the
machine's monotonic clock, when it answered and when the next frame came: the driver's gap.
The driver sends a frame the moment the reply is in, like the scheduler. Meanwhile the main
event loop runs ``--workers`` tasks that each burn 0.2-1.5 ms of CPU and yield, as request
handlers do (the outside benchmark's profile: HTTP is most of the loop's CPU under load).
Variants: the driver on the main loop; in its own thread (and loop) with the interpreter's
switch interval at its default (5 ms) and at 0.5 ms (``sys.setswitchinterval``): a thread
that wakes for a reply waits for the GIL up to that long while the main thread computes.

    .venv/bin/python bench/line_thread_lab.py --seconds 3
"""

from __future__ import annotations

import argparse
import asyncio
import json
import random
import socket
import subprocess
import sys
import threading
import time
from typing import Any

PEER = r"""
import asyncio, json, sys, time
gaps = []
class Peer(asyncio.Protocol):
    def connection_made(self, t):
        self.t, self.answered = t, None
    def data_received(self, data):
        now = time.monotonic()
        if self.answered is not None:
            gaps.append(now - self.answered)
        asyncio.get_running_loop().call_later(0.001, self.answer)
    def answer(self):
        self.t.write(b">\r")
        self.answered = time.monotonic()
    def connection_lost(self, exc):
        print(json.dumps(gaps), flush=True)
        done.set_result(None)
async def main():
    global done
    done = asyncio.get_running_loop().create_future()
    server = await asyncio.get_running_loop().create_server(Peer, "127.0.0.1", int(sys.argv[1]))
    print("ready", flush=True)
    await done
asyncio.run(main())
"""


def new_loop() -> asyncio.AbstractEventLoop:
    try:
        import uvloop
    except ImportError:
        return asyncio.new_event_loop()
    return uvloop.new_event_loop()


async def drive(port: int, until: float) -> None:
    """Send a frame, await its reply, send the next at once (the scheduler's rhythm)."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    sock = writer.get_extra_info("socket")
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    while time.monotonic() < until:
        writer.write(b"$1\r")
        await reader.readuntil(b"\r")
    writer.close()


async def http_like(until: float, pause: float) -> None:
    """A request handler's CPU in slices, then up to ``pause`` seconds without work."""
    while time.monotonic() < until:
        end = time.perf_counter() + random.uniform(0.0002, 0.0015)
        while time.perf_counter() < end:
            pass
        await asyncio.sleep(random.uniform(0, pause))


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def run(variant: str, seconds: float, workers: int, pause: float) -> dict[str, Any]:
    port = free_port()
    peer = subprocess.Popen(
        [sys.executable, "-c", PEER, str(port)], stdout=subprocess.PIPE, text=True
    )
    assert peer.stdout is not None and "ready" in peer.stdout.readline()
    sys.setswitchinterval(0.0005 if variant == "thread, switch interval 0.5 ms" else 0.005)
    until = time.monotonic() + seconds

    async def main() -> None:
        load = [asyncio.create_task(http_like(until, pause)) for _ in range(workers)]
        if variant == "same loop":
            await drive(port, until)
        else:
            line = threading.Thread(
                target=lambda: new_loop().run_until_complete(drive(port, until))
            )
            line.start()
            await asyncio.sleep(seconds)
            await asyncio.to_thread(line.join)
        await asyncio.gather(*load)

    loop = new_loop()
    loop.run_until_complete(main())
    loop.close()
    gaps = sorted(json.loads(peer.stdout.readline()))
    peer.wait()
    sys.setswitchinterval(0.005)

    def pct(q: float) -> float:
        return round(gaps[round(q * (len(gaps) - 1))] * 1000, 3)

    return {"exchanges": len(gaps), "gap_ms_p50": pct(0.5), "gap_ms_p99": pct(0.99)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--workers", type=int, default=12)
    parser.add_argument(
        "--pause-ms", type=float, default=60.0, help="a worker's longest pause between slices"
    )
    args = parser.parse_args()
    variants = ["same loop", "thread, switch interval 5 ms", "thread, switch interval 0.5 ms"]
    figures: dict[str, Any] = {"workers": args.workers, "pause_ms": args.pause_ms}
    for workers in (0, args.workers):
        for variant in variants:
            figures[f"{variant}, {workers} busy tasks"] = run(
                variant, args.seconds, workers, args.pause_ms / 1000
            )
    print(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
