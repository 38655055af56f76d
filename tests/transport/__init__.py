"""Tests of gateway.transport, and what they share.

Every line is tested through the simulator behind it: in process (``SimPort``), on a
pseudo-terminal (``PtyLine``), over TCP (``serve_tcp``) and behind an RFC 2217 server. The
manual's own exchanges are the yardstick: ``$1`` CR -> ``>$10`` CR (§8-1 (III) 通信確認,
§9-2 table) and ``$1OH`` CR -> ``>$105000`` CR (§10 OH, factory value 5000 in §16).
"""

from __future__ import annotations

import asyncio
from types import TracebackType

from gateway.sim.cli import build_loop
from gateway.sim.clock import SimClock
from gateway.sim.loop import SimLoop
from gateway.transport import Transport, TransportClosed

#: §8-1 (III): the communication check and the answer of body 1.
CHECK, CHECK_REPLY = b"$1\r", b">$10\r"
#: §10 OH: the high-speed setting of body 1 (factory value 5000, §16).
OH, OH_REPLY = b"$1OH\r", b">$105000\r"
#: Seconds within which a lost line must show as TransportClosed ("promptly").
PROMPT = 2.0
#: The longest the event loop may be kept from a 5 ms ticker while lines open and close (s):
#: above the scheduling noise of a host with both cores busy (gaps of 150 ms seen), below
#: pyserial's blocking steps (0.3 s in an RFC 2217 close, a TCP connect's whole wait).
STALL = 0.25


def make_sim(bodies: str = "1", *, baud: int = 9600) -> SimLoop:
    """A loop of simulated controllers at real time (scale 1)."""
    return build_loop(list(bodies), clock=SimClock(1.0), baud=baud)


async def reply(line: Transport, timeout: float = 5.0) -> bytes:
    """Read up to and including the next CR (a whole reply, however it was chunked)."""
    data = b""

    async def until_cr() -> None:
        nonlocal data
        while not data.endswith(b"\r"):
            data += await line.read()

    await asyncio.wait_for(until_cr(), timeout)
    return data


async def exchange(line: Transport, frame: bytes, timeout: float = 5.0) -> bytes:
    """Send one frame and return its reply."""
    line.write(frame)
    return await reply(line, timeout)


async def lost(line: Transport, timeout: float = PROMPT) -> TransportClosed:
    """Read until the line reports it is gone (within ``timeout`` s); that error."""

    async def drain() -> TransportClosed:
        while True:
            try:
                await line.read()
            except TransportClosed as exc:
                return exc

    return await asyncio.wait_for(drain(), timeout)


class Ticker:
    """Measures how late the event loop runs a task that sleeps ``period`` s at a time.

    ``max_gap`` is the longest time between two ticks: ``period`` plus however long the loop was
    busy with something else (a blocking call on it shows up here).
    """

    def __init__(self, period: float = 0.005) -> None:
        self.period = period
        self.max_gap = 0.0
        self.ticks = 0
        self._last = 0.0
        self._task: asyncio.Task[None] | None = None
        self._started = asyncio.Event()

    def _tick(self) -> None:
        now = asyncio.get_running_loop().time()
        self.max_gap = max(self.max_gap, now - self._last)
        self._last = now

    async def _run(self) -> None:
        self._last = asyncio.get_running_loop().time()
        self._started.set()
        while True:
            await asyncio.sleep(self.period)
            self._tick()
            self.ticks += 1

    async def __aenter__(self) -> Ticker:
        self._task = asyncio.create_task(self._run())
        await asyncio.wait_for(self._started.wait(), 5)
        return self

    async def __aexit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        assert self._task is not None
        self._tick()  # a stall at the very end counts too
        self._task.cancel()
        await asyncio.gather(self._task, return_exceptions=True)
