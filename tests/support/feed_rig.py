"""The feed without a server: a state cache fed by hand, and what a client's queue holds."""

from __future__ import annotations

from typing import Any

from gateway.bus.events import ReplyObserved
from gateway.bus.state import StateCache
from gateway.protocol.command_text import parse
from gateway.service.config import WsSettings
from gateway.service.feed import Feed, FeedClient
from gateway.service.runtime.simulated import simulated_config
from gateway.service.topology import Topology
from tests.support.ws_server import check_server_message


def make_feed(replay: int = 10_000, backlog: int = 1_000) -> tuple[Feed, StateCache]:
    cache = StateCache()
    topology = Topology(simulated_config(("1", "2")))
    settings = WsSettings(replay=replay, backlog=backlog)
    return Feed(topology, cache, None, settings, clock=lambda: 1_700_000_000.25), cache


def position(cache: StateCache, body: str, motor: int, pulses: int, time: float = 1.0) -> None:
    command = parse(f"6{motor}")  # §10 6: the position counter of one motor
    cache.handle(ReplyObserved(loop="sim", time=time, body=body, command=command, value=pulses))


def drain(client: FeedClient) -> list[dict[str, Any]]:
    out = []
    while client.pending:
        out.append(check_server_message(client.get_nowait() or ""))
    return out
