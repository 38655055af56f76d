"""What a running gateway says, for a test of real processes to wait on: its WebSocket events
(kept), a link event told apart, a worker's sample in ``/metrics``, its simulator's control."""

from __future__ import annotations

import asyncio
import json
import re
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import Any

from websockets.asyncio.client import connect

#: Real seconds to wait for a matching event.
WAIT = 30.0


class Events:
    """Every WebSocket event of the gateway, kept; ``until(check)`` the first that matches."""

    def __init__(self) -> None:
        self.seen: list[dict[str, Any]] = []
        self.came = asyncio.Event()

    async def until(self, check: Callable[[dict[str, Any]], bool]) -> dict[str, Any]:
        try:
            async with asyncio.timeout(WAIT):
                while True:
                    for event in self.seen:
                        if check(event):
                            return event
                    self.came.clear()
                    await self.came.wait()
        except TimeoutError:
            raise AssertionError(f"no such message; the last ones: {self.seen[-8:]}") from None


@asynccontextmanager
async def ws_events(url: str) -> AsyncIterator[Events]:
    """The events, loops and axes of the gateway at ``url`` (``http://host:port``)."""
    events = Events()
    async with connect(url.replace("http", "ws", 1) + "/api/v1/ws") as ws:
        await ws.send(json.dumps({"type": "subscribe", "topics": ["events", "loop:*", "axis:*"]}))

        async def read() -> None:
            async for raw in ws:
                events.seen.append(json.loads(raw))
                events.came.set()

        reader = asyncio.create_task(read())
        try:
            yield events
        finally:
            reader.cancel()


async def sim_control(port: int, *, limit: int = 2**16, **request: Any) -> dict[str, Any]:
    """One request to a simulator's control surface (``--control``); its answer, ``ok``
    (``limit``: the longest answer line read, larger for a trace of a whole run)."""
    reader, writer = await asyncio.wait_for(
        asyncio.open_connection("127.0.0.1", port, limit=limit), WAIT
    )
    try:
        writer.write(json.dumps(request).encode() + b"\n")
        reply: dict[str, Any] = json.loads(await asyncio.wait_for(reader.readline(), WAIT))
    finally:
        writer.close()
    assert reply.get("ok"), reply
    return reply


def is_link(event: dict[str, Any], loop: str, up: bool, says: str = "") -> bool:
    """``event`` says that ``loop`` went up (or down), its cause containing ``says``."""
    data = event.get("data") or {}
    return (
        event.get("type") == "event"
        and data.get("loop") == loop
        and data.get("up") is up
        and says in (data.get("cause") or "")
    )


def worker_sample(metrics: str, name: str, worker: str) -> float:
    """The value of metric ``name`` for line worker ``worker`` in a ``/metrics`` text."""
    found = re.search(rf'^{name}{{worker="{worker}"}} (\S+)$', metrics, re.M)
    assert found, metrics
    return float(found[1])
