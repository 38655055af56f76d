"""SerialLine on ``rfc2217://``: the simulator behind an RFC 2217 (Telnet COM port) server.

The server is pyserial's own ``PortManager`` (the engine of its rfc2217_server example) on an
asyncio TCP server, with the simulated loop as its serial port. Its ``SerialSettings`` record
what the client negotiated, as a real server would set its UART.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator

import pytest
from serial import rfc2217  # type: ignore[import-untyped]

from gateway.sim.loop import SimLoop
from gateway.sim.serve import SimPort
from gateway.transport import SerialLine, TransportClosed, open_transport
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

# pyserial 3.5's RFC 2217 client still calls Thread.setDaemon/setName.
pytestmark = pytest.mark.filterwarnings(r"ignore:set(Daemon|Name)\(\) is deprecated")


class SerialSettings:
    """What ``PortManager`` reads and sets on the server's serial port."""

    def __init__(self) -> None:
        self.baudrate = 9600
        self.bytesize, self.parity, self.stopbits = 7, "E", 2  # changed by the client
        self.xonxoff = self.rtscts = self.break_condition = False
        self.dtr = self.rts = self.cts = self.dsr = self.ri = self.cd = False

    def reset_input_buffer(self) -> None:
        pass

    def reset_output_buffer(self) -> None:
        pass


class _Session(asyncio.Protocol):
    """One client: Telnet/RFC 2217 in, the simulator's bytes (escaped) out."""

    def __init__(self, server: Rfc2217Server) -> None:
        self.server = server

    def write(self, data: bytes) -> None:  # PortManager's way to the network
        self.transport.write(data)

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        self.manager = rfc2217.PortManager(self.server.settings, self)
        self.port = SimPort(self.server.sim)
        self.pump = asyncio.create_task(self._pump())
        self.server.sessions.append(self)

    async def _pump(self) -> None:
        while data := await self.port.reader.read(4096):
            self.transport.write(b"".join(self.manager.escape(data)))

    def data_received(self, data: bytes) -> None:
        payload = b"".join(self.manager.filter(data))
        if payload:
            self.port.write(payload)

    def connection_lost(self, exc: Exception | None) -> None:
        self.pump.cancel()
        self.port.close()


class Rfc2217Server:
    def __init__(self, sim: SimLoop) -> None:
        self.sim = sim
        self.settings = SerialSettings()
        self.sessions: list[_Session] = []
        self.server: asyncio.Server | None = None
        self.url = ""

    async def start(self) -> None:
        self.server = await asyncio.get_running_loop().create_server(
            lambda: _Session(self), "127.0.0.1", 0
        )
        self.url = f"rfc2217://127.0.0.1:{self.server.sockets[0].getsockname()[1]}"

    async def stop(self) -> None:
        assert self.server is not None
        self.server.close()
        for session in self.sessions:
            session.transport.close()
        await asyncio.gather(*(s.pump for s in self.sessions), return_exceptions=True)
        await self.server.wait_closed()


@pytest.fixture
async def server(sim: SimLoop) -> AsyncIterator[Rfc2217Server]:
    rfc = Rfc2217Server(sim)
    await rfc.start()
    yield rfc
    with contextlib.suppress(AssertionError):
        await rfc.stop()


async def test_exchange_at_the_configured_baud_8n1(server: Rfc2217Server) -> None:
    line = open_transport(server.url, 1200)
    await line.open()
    try:
        # the server's port was set as configured: 1200 bps (§10 ES), 8N1 (§2)
        settings = server.settings
        assert (settings.baudrate, settings.bytesize, settings.parity, settings.stopbits) == (
            1200,
            8,
            "N",
            1,
        )
        assert await exchange(line, CHECK) == CHECK_REPLY
        assert await exchange(line, OH) == OH_REPLY
    finally:
        await line.close()


async def test_read_raises_soon_after_the_server_goes_away(server: Rfc2217Server) -> None:
    line = SerialLine(server.url, 9600)
    await line.open()
    assert await exchange(line, CHECK) == CHECK_REPLY
    await server.stop()
    error = await lost(line)
    assert "lost" in str(error)
    with pytest.raises(TransportClosed):
        line.write(CHECK)
    await line.close()


async def test_open_and_close_do_not_stall_the_event_loop(server: Rfc2217Server) -> None:
    # pyserial's RFC 2217 open negotiates (polling with sleeps) and its close sleeps 0.3 s:
    # both must happen off the event loop.
    loop = asyncio.get_running_loop()
    async with Ticker() as ticker:
        line = SerialLine(server.url, 9600)
        await line.open()
        assert await exchange(line, CHECK) == CHECK_REPLY
        started = loop.time()
        await line.close()
        closing = loop.time() - started
    assert closing >= 0.3  # the slow close did happen...
    assert ticker.max_gap < STALL  # ...and the loop kept running meanwhile


async def test_discard_input_and_reopen(server: Rfc2217Server) -> None:
    line = SerialLine(server.url, 9600)
    await line.open()
    line.write(CHECK)
    await asyncio.wait_for(line.wait_pending(len(CHECK_REPLY)), 5)
    assert line.discard_input() == CHECK_REPLY
    assert await exchange(line, OH) == OH_REPLY
    await line.close()
    with pytest.raises(TransportClosed):
        line.write(CHECK)
    await line.open()
    assert await exchange(line, CHECK) == CHECK_REPLY
    await line.close()
