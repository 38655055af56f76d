"""Fan-out straight to the socket: found behind uvicorn's ASGI ``send``, frames a client's
WebSocket library reads as the same text, in order with what goes through the queue."""

from __future__ import annotations

import json

import pytest
from websockets.frames import Frame, Opcode
from websockets.streams import StreamReader

from gateway.api.ws_direct import text_frame

from .conftest import MakeWsServer


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
