"""PipeTransport: the simulator in process, through its ``SimPort``."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator

import pytest

from gateway.sim.loop import SimLoop
from gateway.sim.serve import SimPort
from gateway.transport import PipeTransport, TransportClosed
from tests.transport import CHECK, CHECK_REPLY, OH, OH_REPLY, exchange, lost, reply


class Ports:
    """A factory of SimPorts on one simulated loop that remembers what it made."""

    def __init__(self, sim: SimLoop) -> None:
        self.sim = sim
        self.made: list[SimPort] = []

    def __call__(self) -> SimPort:
        port = SimPort(self.sim)
        self.made.append(port)
        return port


@pytest.fixture
async def line(sim: SimLoop) -> AsyncIterator[PipeTransport]:
    transport = PipeTransport(Ports(sim), url="pipe://sim")
    await transport.open()
    yield transport
    await transport.close()


async def test_exchange_as_in_the_manual(line: PipeTransport) -> None:
    assert line.is_open
    assert await exchange(line, CHECK) == CHECK_REPLY
    assert await exchange(line, OH) == OH_REPLY


async def test_read_raises_soon_after_the_peer_goes_away(sim: SimLoop) -> None:
    ports = Ports(sim)
    line = PipeTransport(ports, url="pipe://sim")
    await line.open()
    assert await exchange(line, CHECK) == CHECK_REPLY
    ports.made[-1].close()  # the simulator's end disconnects
    error = await lost(line)
    assert "pipe://sim" in str(error) and "closed" in str(error)
    assert not line.is_open
    with pytest.raises(TransportClosed, match="pipe://sim"):
        line.write(CHECK)
    await line.close()


async def test_reopen_makes_a_new_peer(sim: SimLoop) -> None:
    ports = Ports(sim)
    line = PipeTransport(ports)
    await line.open()
    ports.made[-1].close()
    await lost(line)
    await line.open()  # the old connection is released, a new peer is made
    assert len(ports.made) == 2
    assert await exchange(line, CHECK) == CHECK_REPLY
    await line.close()


async def test_write_on_a_closed_line_raises(sim: SimLoop) -> None:
    line = PipeTransport(Ports(sim))
    with pytest.raises(TransportClosed, match="not open"):
        line.write(CHECK)
    await line.open()
    await line.close()
    with pytest.raises(TransportClosed):
        line.write(CHECK)
    with pytest.raises(TransportClosed):
        await line.read()
    await line.close()  # closing twice does nothing


async def test_close_wakes_a_waiting_reader(line: PipeTransport) -> None:
    reader = asyncio.create_task(line.read())
    done, _ = await asyncio.wait({reader}, timeout=0.05)  # it starts, and waits: nothing came
    assert not done
    await line.close()
    with pytest.raises(TransportClosed, match="closed by the gateway"):
        await asyncio.wait_for(reader, 2)


async def test_close_lets_another_host_on(sim: SimLoop) -> None:
    line = PipeTransport(Ports(sim))
    await line.open()
    await line.close()
    other = SimPort(sim)  # the simulated line takes one host at a time: ours must be gone
    other.write(CHECK)
    assert await asyncio.wait_for(other.reader.readexactly(5), 5) == CHECK_REPLY
    other.close()


async def test_open_fails_clearly_when_the_peer_refuses(sim: SimLoop) -> None:
    squatter = SimPort(sim)  # another host holds the simulated line
    line = PipeTransport(Ports(sim), url="pipe://busy")
    with pytest.raises(TransportClosed, match=r"pipe://busy: cannot open: .*host"):
        await line.open()
    assert not line.is_open
    squatter.close()
    await line.open()
    assert await exchange(line, CHECK) == CHECK_REPLY
    await line.close()


async def test_discard_input_drops_stale_bytes(line: PipeTransport) -> None:
    line.write(CHECK)
    await asyncio.wait_for(line.wait_pending(len(CHECK_REPLY)), 5)
    assert line.pending == len(CHECK_REPLY)
    assert line.discard_input() == CHECK_REPLY  # returned for the trace
    assert line.pending == 0
    assert await exchange(line, OH) == OH_REPLY  # only the fresh reply, nothing stale before it


async def test_bytes_that_arrived_before_the_loss_are_still_read(sim: SimLoop) -> None:
    ports = Ports(sim)
    line = PipeTransport(ports)
    await line.open()
    line.write(CHECK)
    await asyncio.wait_for(line.wait_pending(len(CHECK_REPLY)), 5)
    ports.made[-1].close()
    assert await reply(line) == CHECK_REPLY
    await lost(line)
    await line.close()
