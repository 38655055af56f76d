"""SerialLine on ``socket://``: the simulator served over TCP (``serve_tcp``).

A ``DeviceServer`` stands for a serial device server (ser2net, a Moxa NPort in TCP-server
mode) with the simulated loop on its serial port: it relays each client to ``serve_tcp``, and
it can go away in an orderly way (FIN), crash (RST) and come back on the same port.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
import struct
from collections.abc import AsyncIterator, Iterator

import pytest

from gateway.sim.loop import SimLoop
from gateway.sim.serve import serve_tcp
from gateway.transport import KeepAlive, SerialLine, TransportClosed, open_transport
from tests.transport import (
    CHECK,
    CHECK_REPLY,
    OH,
    OH_REPLY,
    STALL,
    Ticker,
    exchange,
    lost,
)


class DeviceServer:
    """A TCP server that relays each client to the simulator's TCP port."""

    def __init__(self, sim_port: int) -> None:
        self.sim_port = sim_port
        self.port = 0
        self._server: asyncio.Server | None = None
        self._sockets: list[asyncio.StreamWriter] = []
        self._handlers: set[asyncio.Task[None]] = set()

    @property
    def url(self) -> str:
        return f"socket://127.0.0.1:{self.port}"

    async def start(self) -> None:
        self._server = await asyncio.start_server(self._handle, "127.0.0.1", self.port)
        self.port = self._server.sockets[0].getsockname()[1]

    async def _handle(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        task = asyncio.current_task()
        assert task is not None
        self._handlers.add(task)
        up_reader, up_writer = await asyncio.open_connection("127.0.0.1", self.sim_port)
        self._sockets += [writer, up_writer]

        async def relay(src: asyncio.StreamReader, dst: asyncio.StreamWriter) -> None:
            with contextlib.suppress(OSError):
                while data := await src.read(4096):
                    dst.write(data)
            dst.close()

        try:
            await asyncio.gather(relay(reader, up_writer), relay(up_reader, writer))
        finally:
            self._handlers.discard(task)

    async def stop(self, *, reset: bool = False) -> None:
        """Go away: close every connection (FIN), or reset it (RST) as a crashed server does."""
        assert self._server is not None
        self._server.close()
        for writer in self._sockets:
            if reset:
                sock = writer.get_extra_info("socket")
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
                writer.transport.abort()
            else:
                writer.close()
        self._sockets.clear()
        # with both ends of every relay closed, the handlers end by themselves
        await asyncio.wait_for(asyncio.gather(*self._handlers, return_exceptions=True), 5)
        await self._server.wait_closed()


@pytest.fixture
async def sim_port(sim: SimLoop) -> AsyncIterator[int]:
    server = await serve_tcp(sim, "127.0.0.1", 0)
    yield server.sockets[0].getsockname()[1]
    server.close()
    await server.wait_closed()


@pytest.fixture
async def device_server(sim_port: int) -> AsyncIterator[DeviceServer]:
    server = DeviceServer(sim_port)
    await server.start()
    yield server
    with contextlib.suppress(AssertionError):
        await server.stop()


@pytest.fixture
def no_answer() -> Iterator[str]:
    """A socket:// address whose TCP connect hangs: the listener's backlog is full."""
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(0)
    port = listener.getsockname()[1]
    fillers: list[socket.socket] = []
    hangs = False
    for _ in range(8):
        filler = socket.socket()
        filler.settimeout(0.2)
        fillers.append(filler)
        try:
            filler.connect(("127.0.0.1", port))
        except TimeoutError:
            hangs = True  # the queue is full: from now on a connect waits
            break
        except OSError:
            break  # refused at once (tcp_abort_on_overflow): nothing to wait for
    try:
        if not hangs:
            pytest.fail(
                "this kernel refuses a connect to a full backlog at once "
                "(net.ipv4.tcp_abort_on_overflow=1?): the open time-out cannot be tested; "
                "set it to 0 (`sysctl -w net.ipv4.tcp_abort_on_overflow=0`)"
            )
        yield f"socket://127.0.0.1:{port}"
    finally:
        for s in [*fillers, listener]:
            s.close()


async def test_exchange_as_in_the_manual(sim_port: int) -> None:
    line = open_transport(f"socket://127.0.0.1:{sim_port}", 9600)
    await line.open()
    try:
        assert await exchange(line, CHECK) == CHECK_REPLY
        assert await exchange(line, OH) == OH_REPLY
    finally:
        await line.close()


async def test_keepalive_is_on(sim_port: int) -> None:
    line = SerialLine(f"socket://127.0.0.1:{sim_port}", 9600, keepalive=KeepAlive(7, 3, 4))
    await line.open()
    try:
        # white box: the connection's own socket, where the kernel keeps the options
        sock = line._port._transport.get_extra_info("socket")  # type: ignore[union-attr]
        assert sock.getsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE) == 1
        assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPIDLE) == 7
        assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPINTVL) == 3
        assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_KEEPCNT) == 4
        assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_USER_TIMEOUT) == 19_000
        assert await exchange(line, CHECK) == CHECK_REPLY
    finally:
        await line.close()


@pytest.mark.parametrize("reset", [False, True], ids=["server-closes", "server-crashes"])
async def test_read_raises_soon_after_the_server_goes_away(
    device_server: DeviceServer, reset: bool
) -> None:
    line = SerialLine(device_server.url, 9600)
    await line.open()
    assert await exchange(line, CHECK) == CHECK_REPLY
    await device_server.stop(reset=reset)
    error = await lost(line)
    assert device_server.url in str(error)
    assert not line.is_open
    with pytest.raises(TransportClosed, match=str(device_server.port)):
        line.write(CHECK)
    await line.close()


async def test_reopen_after_the_server_comes_back(device_server: DeviceServer) -> None:
    line = SerialLine(device_server.url, 9600)
    await line.open()
    assert await exchange(line, CHECK) == CHECK_REPLY
    await device_server.stop()
    await lost(line)
    with pytest.raises(TransportClosed, match="cannot open"):
        await line.open()  # nothing listens: refused
    await device_server.start()  # back, on the same port
    await line.open()
    assert await exchange(line, OH) == OH_REPLY
    await line.close()


async def test_open_gives_up_on_a_server_that_does_not_answer(no_answer: str) -> None:
    line = SerialLine(no_answer, 9600, open_timeout=0.5)
    loop = asyncio.get_running_loop()
    started = loop.time()
    async with Ticker() as ticker:
        with pytest.raises(TransportClosed, match=r"cannot open: no connection within 0.5 s"):
            await line.open()
    assert 0.4 < loop.time() - started < 2.0
    assert ticker.max_gap < STALL  # s: the connect waited off the event loop


async def test_open_and_close_do_not_stall_the_event_loop(sim_port: int) -> None:
    async with Ticker() as ticker:
        for _ in range(5):
            line = SerialLine(f"socket://127.0.0.1:{sim_port}", 9600)
            await line.open()
            assert await exchange(line, CHECK) == CHECK_REPLY
            await line.close()
    assert ticker.max_gap < STALL


async def test_discard_input_drops_stale_bytes(sim_port: int) -> None:
    line = SerialLine(f"socket://127.0.0.1:{sim_port}", 9600)
    await line.open()
    try:
        line.write(CHECK)
        await asyncio.wait_for(line.wait_pending(len(CHECK_REPLY)), 5)
        assert line.discard_input() == CHECK_REPLY
        assert await exchange(line, OH) == OH_REPLY
    finally:
        await line.close()
