"""SerialLine on a device path: the simulator behind a pseudo-terminal (``PtyLine``)."""

from __future__ import annotations

import asyncio
import os
import termios
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from gateway.sim.loop import SimLoop
from gateway.sim.serve import PtyLine
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


@pytest.fixture
async def pty(sim: SimLoop) -> AsyncIterator[PtyLine]:
    line = PtyLine(sim)
    line.start()
    yield line
    line.close()


def attrs(path: str) -> list[int]:
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        return termios.tcgetattr(fd)
    finally:
        os.close(fd)


async def test_exchange_as_in_the_manual(pty: PtyLine) -> None:
    line = open_transport(pty.path, 9600)
    await line.open()
    try:
        assert await exchange(line, CHECK) == CHECK_REPLY
        assert await exchange(line, OH) == OH_REPLY
    finally:
        await line.close()


@pytest.mark.parametrize(("baud", "speed"), [(9600, termios.B9600), (1200, termios.B1200)])
async def test_port_is_set_to_the_configured_baud_8n1(pty: PtyLine, baud: int, speed: int) -> None:
    line = open_transport(pty.path, baud)
    await line.open()
    try:
        iflag, _, cflag, _, ispeed, ospeed, _ = attrs(pty.path)
    finally:
        await line.close()
    assert (ispeed, ospeed) == (speed, speed)  # §2: the rate from the configuration
    assert cflag & termios.CSIZE == termios.CS8  # §2: 8 data bits
    assert not cflag & (termios.PARENB | termios.CSTOPB)  # no parity, 1 stop bit
    assert not cflag & termios.CRTSCTS  # §13-1: only TXD and RXD, no flow control
    assert not iflag & (termios.IXON | termios.IXOFF | termios.ICRNL)  # no XON/XOFF, CR kept


async def test_read_raises_soon_after_the_pty_is_closed(sim: SimLoop) -> None:
    pty = PtyLine(sim)
    pty.start()
    line = SerialLine(pty.path, 9600)
    await line.open()
    assert await exchange(line, CHECK) == CHECK_REPLY
    pty.close()  # the device vanishes, as a USB adapter pulled out
    error = await lost(line)
    assert pty.path in str(error) and "lost" in str(error)
    assert not line.is_open
    with pytest.raises(TransportClosed, match="lost"):
        line.write(CHECK)
    await line.close()


async def test_reopen_after_the_device_comes_back(sim: SimLoop, tmp_path: Path) -> None:
    # A stable name for a device that comes back at another /dev/pts/N, as udev's
    # /dev/serial/by-id links do for a re-plugged USB adapter.
    link = tmp_path / "ttyRC233"
    first = PtyLine(sim)
    link.symlink_to(first.start())
    line = SerialLine(str(link), 9600)
    await line.open()
    assert await exchange(line, CHECK) == CHECK_REPLY
    first.close()
    await lost(line)
    with pytest.raises(TransportClosed, match="cannot open"):
        await line.open()  # not back yet
    second = PtyLine(sim)
    link.unlink()
    link.symlink_to(second.start())
    try:
        await line.open()
        assert await exchange(line, OH) == OH_REPLY
        await line.close()
    finally:
        second.close()


async def test_close_and_open_again(pty: PtyLine) -> None:
    line = SerialLine(pty.path, 9600)
    for _ in range(3):
        await line.open()
        assert await exchange(line, CHECK) == CHECK_REPLY
        await line.close()
        with pytest.raises(TransportClosed):
            line.write(CHECK)


async def test_a_second_program_cannot_take_the_port(pty: PtyLine) -> None:
    line = SerialLine(pty.path, 9600)
    await line.open()
    other = SerialLine(pty.path, 9600)
    try:
        with pytest.raises(TransportClosed, match="cannot open"):
            await other.open()  # two hosts on one loop would garble each other's frames
        assert await exchange(line, CHECK) == CHECK_REPLY
    finally:
        await line.close()
    await other.open()  # free once the first closed it
    await other.close()


async def test_missing_device_fails_to_open(tmp_path: Path) -> None:
    line = SerialLine(str(tmp_path / "ttyUSB9"), 9600)
    with pytest.raises(TransportClosed, match="ttyUSB9: cannot open"):
        await line.open()
    assert not line.is_open


async def test_discard_input_drops_stale_bytes(pty: PtyLine) -> None:
    line = SerialLine(pty.path, 9600)
    await line.open()
    try:
        line.write(CHECK)
        await asyncio.wait_for(line.wait_pending(len(CHECK_REPLY)), 5)
        assert line.discard_input() == CHECK_REPLY
        assert await exchange(line, OH) == OH_REPLY
    finally:
        await line.close()


async def test_open_and_close_do_not_stall_the_event_loop(pty: PtyLine) -> None:
    async with Ticker() as ticker:
        for _ in range(5):
            line = SerialLine(pty.path, 9600)
            await line.open()
            line.write(CHECK)
            await line.close()
    assert ticker.max_gap < STALL  # s; a blocking open or close would show here
