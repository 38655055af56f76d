"""What an MES does with rc233-gateway, as a Python program (httpx and websockets).

    pip install httpx websockets
    python examples/mes_client.py --url http://127.0.0.1:8233 [--token TOKEN] [--axis x]

It homes an axis and waits for the end, moves it with ``?wait=true``, and makes every POST
safe to retry: each request carries an ``Idempotency-Key``, and when the connection drops
before the answer arrives (did the move happen or not?) the same request is sent again with
the same key, so the gateway answers with the first result instead of moving twice. A
WebSocket watcher follows the axis, loses its connection, and resumes with ``since``: the
gateway replays what it missed, or sends a fresh snapshot when it can no longer replay.

Each step prints one line; ``tests/test_examples.py`` runs this file against
``rc233-gateway serve --simulate``. Nothing here is private to the gateway: the routes,
headers and messages are those of openapi/openapi.json and openapi/asyncapi.json.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import sys
import uuid
from typing import Any

import httpx
from websockets.asyncio.client import connect

#: How often a request is sent again after the connection dropped, and the pause between.
ATTEMPTS = 5
BACKOFF = 0.5


class Gateway:
    """The few calls an MES needs, every POST retried safely."""

    def __init__(self, url: str, token: str | None) -> None:
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self.url = url.rstrip("/")
        self.token = token
        self.http = httpx.AsyncClient(
            base_url=f"{self.url}/api/v1", headers=headers, timeout=httpx.Timeout(60.0)
        )

    async def post(self, path: str, body: dict[str, Any], **params: Any) -> dict[str, Any]:
        """POST with an Idempotency-Key; sent again with the same key if no answer came."""
        key = str(uuid.uuid4())
        for attempt in range(1, ATTEMPTS + 1):
            try:
                response = await self.http.post(
                    path, json=body, params=params, headers={"Idempotency-Key": key}
                )
            except httpx.TransportError as exc:  # the answer was lost: the request may have acted
                print(f"retry {path} (attempt {attempt}): {type(exc).__name__}, same key {key}")
                await asyncio.sleep(BACKOFF)
                continue
            if response.status_code == 503 and attempt < ATTEMPTS:  # loop down: nothing was done
                await asyncio.sleep(float(response.headers.get("Retry-After", BACKOFF)))
                continue
            if response.headers.get("Idempotent-Replayed") == "true":
                print(f"replayed {path}: the gateway answered the first request again")
            if response.is_error:
                problem = response.json()
                raise RuntimeError(f"{path}: {response.status_code} {problem.get('detail')}")
            result: dict[str, Any] = response.json()
            return result
        raise RuntimeError(f"{path}: no answer after {ATTEMPTS} attempts")

    async def home(self, axis: str, method: str = "0") -> dict[str, Any]:
        """Home and wait for the end (a search takes about 25 s at real speed)."""
        op = await self.post(f"/axes/{axis}/home", {"method": method}, wait="true", timeout=60)
        if op["state"] != "done":
            raise RuntimeError(f"home {axis}: {op['state']} {op.get('error')}")
        return op

    async def move(self, axis: str, position: float, unit: str = "user") -> dict[str, Any]:
        """Move to ``position`` (in the axis's user unit, or pulses) and wait for the end."""
        body = {"position": position, "unit": unit}
        op = await self.post(f"/axes/{axis}/move", body, wait="true", timeout=60)
        if op["state"] != "done":
            raise RuntimeError(f"move {axis}: {op['state']} {op.get('error')}")
        return op

    def ws_url(self) -> str:
        """The WebSocket's URL (the token as a query parameter, which any client can send)."""
        base = self.url.replace("https://", "wss://").replace("http://", "ws://")
        return f"{base}/api/v1/ws" + (f"?token={self.token}" if self.token else "")


class Watcher:
    """Follows topics on the WebSocket and resumes after a reconnect with ``since``."""

    def __init__(self, gateway: Gateway, topics: list[str]) -> None:
        self.gateway = gateway
        self.topics = topics
        self.last_seq: int | None = None
        self.stream: str | None = None
        self.positions: list[int | None] = []

    def _take(self, message: dict[str, Any]) -> None:
        if "seq" in message:
            self.last_seq = max(self.last_seq or 0, message["seq"])
        if message["type"] in ("snapshot", "subscribed"):
            self.stream = message["stream"]
        if message["type"] == "snapshot":
            self.positions += [a["position"] for a in message["axes"]]
        elif message["type"] == "change" and "position" in message["changed"]:
            self.positions.append(message["data"]["position"])

    async def session(self, *until: str) -> list[dict[str, Any]]:
        """One connection: subscribe (resuming when it can) and read until a message of one
        of the types ``until``; the messages read."""
        subscribe: dict[str, Any] = {"type": "subscribe", "topics": self.topics}
        if self.last_seq is not None:
            subscribe |= {"since": self.last_seq, "stream": self.stream}
        seen: list[dict[str, Any]] = []
        async with connect(self.gateway.ws_url(), compression=None) as ws:
            await ws.send(json.dumps(subscribe))
            while not seen or seen[-1]["type"] not in until:
                message = json.loads(await asyncio.wait_for(ws.recv(), 30))
                self._take(message)
                seen.append(message)
        return seen


async def run(url: str, token: str | None, axis: str) -> None:
    """The demonstration: home, move, retry safely, watch and resume."""
    gateway = Gateway(url, token)
    async with gateway.http:
        op = await gateway.home(axis)
        print(f"home {axis}: {op['state']} at {op['position']} pulses")
        op = await gateway.move(axis, 12.5)
        print(f"move {axis}: {op['state']} at {op['position_user']} ({op['position']} pulses)")

        watcher = Watcher(gateway, [f"axis:{axis}"])
        await watcher.session("snapshot")
        print(f"watch {axis}: snapshot at seq {watcher.last_seq}, position {watcher.positions[-1]}")
        # Disconnected: the axis moves meanwhile.
        op = await gateway.move(axis, 20.0)
        print(f"move {axis}: {op['state']} at {op['position_user']} ({op['position']} pulses)")
        # Caught up by a replay of what was missed (``subscribed`` after it), or by a fresh
        # snapshot when the gateway restarted or the replay buffer no longer reaches back.
        last = (await watcher.session("subscribed", "snapshot"))[-1]
        how = (
            f"{last['replayed']} missed messages replayed"
            if last["type"] == "subscribed"
            else "a fresh snapshot"
        )
        print(f"resume {axis}: {how}, position {watcher.positions[-1]}")


def main() -> int:
    """Command line of the example."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--url", default="http://127.0.0.1:8233")
    parser.add_argument("--token", default=os.environ.get("RC233_TOKEN"))
    parser.add_argument("--axis", default="x")
    args = parser.parse_args()
    try:
        asyncio.run(run(args.url, args.token, args.axis))
    except RuntimeError as exc:
        print(f"failed: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
