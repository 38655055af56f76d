"""The reply parser is fed from the transport's ``data_received``: no reader task woken per
chunk, and a reply cut into single bytes gives exactly what the whole reply gives."""

from __future__ import annotations

import asyncio

from gateway.bus.config import LoopConfig
from gateway.bus.events import BusEvent, ReplyObserved
from gateway.bus.scheduler import LoopScheduler
from gateway.protocol.command_text import parse
from gateway.sim.serve import SimPort
from gateway.transport.base import ReceiveBuffer, Sink, TransportClosed
from gateway.transport.pipe import PipeTransport
from tests.support.bus_rig import HOST_LATENCY, SCALE, Bus, MakeBus

QUERIES = ["", "9", "A005D", "2D", "OX", "97"]


class OneByteReader:
    """What the simulator sends, handed on one byte a read: a chunk a byte."""

    def __init__(self, inner: asyncio.StreamReader) -> None:
        self._inner = inner
        self._left = b""

    async def read(self, size: int) -> bytes:
        if not self._left:
            self._left = await self._inner.read(size)
        byte, self._left = self._left[:1], self._left[1:]
        return byte


class OneBytePeer:
    """A simulator port whose replies arrive a byte at a time."""

    def __init__(self, port: SimPort) -> None:
        self._port = port
        self.reader = OneByteReader(port.reader)

    def write(self, data: bytes) -> None:
        self._port.write(data)

    def close(self) -> None:
        self._port.close()


async def _replies(scheduler: LoopScheduler) -> list[tuple[str, object]]:
    seen: list[BusEvent] = []
    stop = scheduler.events.subscribe(seen.append)
    try:
        for text in QUERIES:
            await scheduler.submit("1", parse(text))
    finally:
        stop()
    return [(e.command.wire(), e.value) for e in seen if isinstance(e, ReplyObserved)]


async def test_replies_reach_their_exchange_with_no_reader_task(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    replies = await _replies(bus.scheduler)
    assert [text for text, _ in replies] == QUERIES
    assert all(value is not None for _, value in replies)
    readers = [t for t in asyncio.all_tasks() if t.get_name() == "bus-reader" and not t.done()]
    assert readers == []


async def test_a_reply_cut_into_single_bytes_gives_what_the_whole_reply_gives(
    make_bus: MakeBus,
) -> None:
    whole = await make_bus("1")
    cut_sim: Bus = await make_bus("1")
    await cut_sim.scheduler.close()  # its line is taken over by one cut into bytes
    transport = PipeTransport(lambda: OneBytePeer(cut_sim.connect()), url="pipe://cut")
    cut = LoopScheduler(transport, LoopConfig(time_scale=SCALE, host_latency=HOST_LATENCY))
    await cut.start()
    try:
        expected = await _replies(whole.scheduler)
        got = await _replies(cut)
        assert got == expected
        counters = cut.snapshot()
        assert (counters.garbled, counters.late_replies, counters.timeouts) == (0, 0, 0)
        assert counters.bytes_in == whole.scheduler.snapshot().bytes_in
    finally:
        await cut.close()


class Taken(Sink):
    def __init__(self) -> None:
        self.chunks: list[bytes] = []
        self.errors: list[str] = []

    def received(self, data: bytes) -> None:
        self.chunks.append(data)

    def closed(self, error: TransportClosed) -> None:
        self.errors.append(str(error))


def test_a_sink_gets_what_waited_then_each_chunk_then_the_close_once() -> None:
    inbox = ReceiveBuffer("pipe://x")
    inbox.feed(b">$1")
    sink = Taken()
    inbox.deliver(sink)
    inbox.feed(b"12")
    inbox.feed(b"\r")
    assert sink.chunks == [b">$1", b"12", b"\r"]
    assert inbox.pending == 0  # nothing kept for a reader
    inbox.close("the peer closed the line")
    inbox.close("again")
    inbox.feed(b"late")
    assert sink.errors == ["pipe://x: the peer closed the line"]
    assert sink.chunks == [b">$1", b"12", b"\r"]


def test_without_a_sink_the_bytes_wait_for_a_reader_again() -> None:
    inbox = ReceiveBuffer("pipe://x")
    sink = Taken()
    inbox.deliver(sink)
    inbox.feed(b">")
    inbox.deliver(None)
    inbox.feed(b">$1\r")
    assert sink.chunks == [b">"]
    assert inbox.discard() == b">$1\r"
