"""Fan-out straight to the socket: found behind uvicorn's ASGI ``send``, frames a client's
WebSocket library reads as the same text, in order with what goes through the queue."""

from __future__ import annotations

import json

import pytest
from websockets.frames import Frame, Opcode
from websockets.streams import StreamReader

from gateway.api.security import AuthConfig, TokenBook, hash_token
from gateway.api.ws import direct as ws_direct
from gateway.api.ws.direct import direct_writer, text_frame
from gateway.bus.state import StateCache
from gateway.service.config import WsSettings
from gateway.service.events import ServiceEvents
from gateway.service.feed import Feed, FeedClient
from gateway.service.runtime.simulated import simulated_config
from gateway.service.topology import Topology
from tests.support.ws_server import (
    VIEWER_TOKEN,
    CountingStats,
    MakeWsServer,
    WsServer,
    start_uvicorn,
    ws_app,
)


@pytest.mark.parametrize("size", [0, 125, 126, 65_535, 65_536, 70_000])
def test_a_text_frame_reads_back_as_its_text(size: int) -> None:
    text = "é" * (size // 2) + "x" * (size % 2)
    reader = StreamReader()
    reader.feed_data(text_frame(text))
    reader.feed_eof()
    parsing = Frame.parse(reader.read_exact, mask=False)
    try:
        next(parsing)
    except StopIteration as done:
        frame = done.value
    else:  # pragma: no cover
        raise AssertionError("the frame was not complete")
    assert (frame.opcode, frame.fin, frame.data.decode()) == (Opcode.TEXT, True, text)


async def test_uvicorn_connections_are_written_directly_in_order(
    make_ws_server: MakeWsServer,
) -> None:
    server = await make_ws_server()
    client = await server.connect()
    first = await client.subscribe("axis:x")
    assert first["type"] == "snapshot"
    (feed_client,) = server.feed._clients
    # The optimisation is there on the server serve runs (and would vanish silently else).
    assert feed_client.direct is not None
    for pulses in range(1, 201):
        server.position("1", 1, pulses)
    positions = []
    while len(positions) < 200:
        message = await client.recv()
        assert message["type"] == "change", json.dumps(message)
        positions.append(message["data"]["position"])
    assert positions == list(range(1, 201))


async def _two_hundred_in_order(server: WsServer) -> list[FeedClient]:
    """Subscribe a client to x, publish 200 positions, and check it read them all in order;
    the feed's clients."""
    client = await server.connect()
    assert (await client.subscribe("axis:x"))["type"] == "snapshot"
    for pulses in range(1, 201):
        server.position("1", 1, pulses)
    positions = []
    while len(positions) < 200:
        message = await client.recv()
        assert message["type"] == "change", json.dumps(message)
        positions.append(message["data"]["position"])
    assert positions == list(range(1, 201))
    return list(server.feed._clients)


async def test_a_direct_writer_that_fails_sends_that_message_and_every_later_one_through_asgi(
    make_ws_server: MakeWsServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    server = await make_ws_server()
    calls = 0
    framed = ws_direct.text_frame

    def failing_after_50(text: str) -> bytes:
        nonlocal calls
        calls += 1
        if calls > 50:
            raise RuntimeError("what uvicorn did not promise changed")
        return framed(text)

    monkeypatch.setattr(ws_direct, "text_frame", failing_after_50)
    (feed_client,) = await _two_hundred_in_order(server)
    assert feed_client.direct is not None
    assert calls == 51  # broken at the 51st: never tried again
    assert feed_client.direct("late") is False
    assert calls == 51


async def test_a_server_whose_protocol_it_does_not_know_gets_no_writer_and_every_message(
    make_ws_server: MakeWsServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    # What a uvicorn with its protocol class renamed (or another server) looks like.
    monkeypatch.setattr(ws_direct, "_PROTOCOL", "SomeOtherProtocol")
    server = await make_ws_server()
    (feed_client,) = await _two_hundred_in_order(server)
    assert feed_client.direct is None


def test_a_look_alike_protocol_without_what_the_writer_reads_gets_no_writer() -> None:
    class WebSocketsSansIOProtocol:  # the name, not the attributes
        transport = None

        async def send(self, message: object) -> None:
            pass

    protocol_send = WebSocketsSansIOProtocol().send  # found behind the ASGI send

    async def asgi_send(message: object) -> None:
        await protocol_send(message)

    assert direct_writer(asgi_send) is None
    assert direct_writer(None) is None


def test_uvicorn_connections_are_written_directly_on_uvloop_too() -> None:
    # serve runs on uvloop, whose transports are not asyncio.Transport subclasses.
    import uvloop  # with uvicorn[standard] on every platform serve runs on

    async def scenario() -> list[FeedClient]:
        token = {"name": "dashboard", "role": "viewer", "sha256": hash_token(VIEWER_TOKEN)}
        config = simulated_config(("1", "2"), tokens=[token])
        cache, stats = StateCache(), CountingStats()
        feed = Feed(Topology(config), cache, ServiceEvents(), WsSettings())
        auth = AuthConfig(TokenBook.from_settings(config.security.tokens))
        uv, port = await start_uvicorn(ws_app(feed, auth, stats))
        server = WsServer(cache, ServiceEvents(), feed, stats, port)
        try:
            return await _two_hundred_in_order(server)
        finally:
            for client in server.clients:
                await client.close()
            feed.close()
            await uv.shutdown()

    (feed_client,) = uvloop.run(scenario())
    assert feed_client.direct is not None
