"""Count the calls a move takes from its route handler to the transport's write.

Runs ``POST /axes/x/move`` against the in-process simulated app of the API tests and records
the gateway's own stack frames at three points: when the operation starts
(``Operations.run``), when the request joins the loop's queue, and when the move's frame
(``$13``) is written. The calls in between are the hops of docs/architecture.md; two task
hand-offs (the operation's send, the loop's task) cut the stack in three.

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
from gateway.service.operations.registry import Operations
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


if __name__ == "__main__":
    asyncio.run(main())
