"""A WebSocket message over the limit is refused before it is read (close 1009)."""

from __future__ import annotations

import asyncio
import json

import pytest
from websockets.exceptions import ConnectionClosed

from gateway.api.ws.endpoint import WS_MESSAGE_LIMIT, uvicorn_ws_options
from gateway.service.config import WsSettings
from tests.support.ws_server import RECV_TIMEOUT, MakeWsServer


async def test_a_message_over_the_limit_closes_with_1009(make_ws_server: MakeWsServer):
    server = await make_ws_server(**uvicorn_ws_options(WsSettings()))
    client = await server.connect()
    ping = {"type": "ping", "id": "x" * (WS_MESSAGE_LIMIT - 100)}  # just under: answered
    await client.send(ping)
    assert (await client.recv())["type"] == "pong"
    await client.send(json.dumps({"type": "ping", "id": "x" * WS_MESSAGE_LIMIT}))
    with pytest.raises(ConnectionClosed) as closed:
        await asyncio.wait_for(client.conn.recv(), RECV_TIMEOUT)
    assert closed.value.rcvd is not None
    assert closed.value.rcvd.code == 1009
