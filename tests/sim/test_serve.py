"""The loop served as a serial line: a pseudo-terminal, TCP, and the ``sim`` subcommand."""

from __future__ import annotations

import asyncio
import json
import logging
import os
import re
import select
import signal
import sys
import time
import tty
from collections.abc import AsyncIterator
from pathlib import Path

import pytest
import serial  # type: ignore[import-untyped]

from gateway.sim.clock import RecordKind
from gateway.sim.loop import SimLoop
from gateway.sim.serve import PtyLine, SimPort, serve_tcp
from tests.support.sim_wire import make_loop

#: The console script of the project, next to the interpreter running the tests.
GATEWAY = Path(sys.executable).parent / "rc233-gateway"
LISTENING = re.compile(r"listening on (\S+)")


def blocking_exchange(path: str, frame: bytes, size: int, timeout: float = 10.0) -> bytes:
    """What a plain program does with a serial port: open, write, read ``size`` bytes, close."""
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
    try:
        tty.setraw(fd)
        os.write(fd, frame)
        out = b""
        deadline = time.monotonic() + timeout
        while len(out) < size:
            ready, _, _ = select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
            if not ready:
                break
            out += os.read(fd, size - len(out))
        return out
    finally:
        os.close(fd)


@pytest.fixture
async def loop() -> AsyncIterator[SimLoop]:
    sim = make_loop("1")
    yield sim
    sim.close()


# ---------------------------------------------------------------------------- PTY


async def test_pty_answers_like_a_serial_port(loop: SimLoop) -> None:
    pty = PtyLine(loop)
    path = pty.start()
    try:
        assert path.startswith("/dev/")
        reply = await asyncio.to_thread(blocking_exchange, path, b"$1\r", 5)
        assert reply == b">$10\r"
        # a second program opening the same port later is served too
        reply = await asyncio.to_thread(blocking_exchange, path, b"$1OH\r", 9)
        assert reply == b">$105000\r"
    finally:
        pty.close()


async def test_pty_with_pyserial(loop: SimLoop) -> None:

    pty = PtyLine(loop)
    path = pty.start()

    def customer() -> bytes:
        with serial.Serial(path, 9600, timeout=10) as port:
            port.write(b"$1\r")
            return bytes(port.read(5))

    try:
        assert await asyncio.to_thread(customer) == b">$10\r"
    finally:
        pty.close()


# ---------------------------------------------------------------------------- TCP


async def test_tcp_takes_one_host_and_refuses_a_second(
    loop: SimLoop, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="gateway.sim")
    server = await serve_tcp(loop, "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    try:
        r1, w1 = await asyncio.open_connection("127.0.0.1", port)
        w1.write(b"$1\r")
        assert await asyncio.wait_for(r1.readexactly(5), 5) == b">$10\r"

        r2, w2 = await asyncio.open_connection("127.0.0.1", port)
        assert await asyncio.wait_for(r2.read(), 5) == b""  # closed at once
        w2.close()
        assert "refused a second host connection" in caplog.text

        w1.write(b"$1OH\r")  # the first host is not disturbed
        assert await asyncio.wait_for(r1.readexactly(9), 5) == b">$105000\r"
        mark = loop.log.next_seq
        w1.close()
        await loop.log.wait_for(
            lambda r: r.kind is RecordKind.HOST and r.note == "disconnected", mark, 5
        )

        r3, w3 = await asyncio.open_connection("127.0.0.1", port)  # the line is free again
        w3.write(b"$1\r")
        assert await asyncio.wait_for(r3.readexactly(5), 5) == b">$10\r"
        w3.close()
    finally:
        server.close()
        await server.wait_closed()


async def test_tcp_with_pyserial_socket_url(loop: SimLoop) -> None:

    server = await serve_tcp(loop, "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]

    def customer() -> bytes:
        with serial.serial_for_url(f"socket://127.0.0.1:{port}", timeout=10) as line:
            line.write(b"$1\r")
            return bytes(line.read(5))

    try:
        assert await asyncio.to_thread(customer) == b">$10\r"
    finally:
        server.close()
        await server.wait_closed()


# ---------------------------------------------------------------------------- the subcommand


async def start_sim(*args: str) -> tuple[asyncio.subprocess.Process, str]:
    """Start ``rc233-gateway sim ARGS``; the process and its 'listening' line."""
    process = await asyncio.create_subprocess_exec(
        str(GATEWAY),
        "sim",
        *args,
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    assert process.stdout is not None
    line = await asyncio.wait_for(process.stdout.readline(), 20)
    if not line:
        assert process.stderr is not None
        raise AssertionError((await process.stderr.read()).decode())
    return process, line.decode()


async def stop(process: asyncio.subprocess.Process, sig: signal.Signals) -> int:
    process.send_signal(sig)
    return await asyncio.wait_for(process.wait(), 20)


async def test_sim_pty_subcommand_prints_the_path_and_stops_on_sigterm(tmp_path: Path) -> None:
    process, line = await start_sim("--pty", "--time-scale", "10", "--eeprom-dir", str(tmp_path))
    try:
        found = LISTENING.search(line)
        assert found, line
        reply = await asyncio.to_thread(blocking_exchange, found.group(1), b"$1\r", 5)
        assert reply == b">$10\r"
    finally:
        code = await stop(process, signal.SIGTERM)
    assert code == 0


async def test_sim_tcp_subcommand_with_control_and_bodies(tmp_path: Path) -> None:
    process, line = await start_sim(
        "--tcp", "127.0.0.1:0", "--control", "127.0.0.1:0", "--bodies", "1,3",
        "--eeprom-dir", str(tmp_path), "--time-scale", "10",
    )  # fmt: skip
    try:
        found = re.search(r"listening on socket://([\d.]+):(\d+)", line)
        control = re.search(r"control ([\d.]+):(\d+)", line)
        assert found and control, line
        reader, writer = await asyncio.open_connection(found.group(1), int(found.group(2)))
        creader, cwriter = await asyncio.open_connection(control.group(1), int(control.group(2)))
        cwriter.write(b'{"op": "ems", "body": "3", "pressed": true}\n')
        assert json.loads(await asyncio.wait_for(creader.readline(), 5)) == {"ok": True}
        writer.write(b"$3\r")
        assert await asyncio.wait_for(reader.readexactly(5), 5) == b">$34\r"
        writer.write(b"$1\r")
        assert await asyncio.wait_for(reader.readexactly(5), 5) == b">$10\r"
        writer.close()
        cwriter.close()
    finally:
        code = await stop(process, signal.SIGINT)
    assert code == 0


async def test_sim_keeps_eeprom_across_restarts(tmp_path: Path) -> None:
    async def session(frames: list[bytes], sizes: list[int]) -> list[bytes]:
        process, line = await start_sim("--tcp", "127.0.0.1:0", "--eeprom-dir", str(tmp_path))
        try:
            found = re.search(r"socket://([\d.]+):(\d+)", line)
            assert found, line
            reader, writer = await asyncio.open_connection(found.group(1), int(found.group(2)))
            out = []
            for frame, size in zip(frames, sizes, strict=True):
                writer.write(frame)
                out.append(await asyncio.wait_for(reader.readexactly(size), 10))
            writer.close()
            return out
        finally:
            assert await stop(process, signal.SIGTERM) == 0

    # §10 DW: '>' at once, '$1*' when written (our write time: 0.1 s)
    assert await session([b"$1OH4000\r", b"$1DW\r"], [1, 1 + 4]) == [b">", b">$1*\r"]
    assert await session([b"$1OH\r"], [9]) == [b">$104000\r"]


def test_bad_options_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    from gateway.sim.cli import main

    for argv in (["--pty", "--bodies", "1,F"], ["--tcp", "nohost"], ["--pty", "--time-scale", "0"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
    assert "body numbers" in capsys.readouterr().err


async def test_the_in_process_port_reads_eof_when_the_loop_closes() -> None:
    # A transport reading the port must learn that the line went away (the loop is then down).
    loop = make_loop()
    port = SimPort(loop)
    port.write(b"$1\r")
    assert await asyncio.wait_for(port.reader.readexactly(5), 5) == b">$10\r"
    loop.close()
    assert await asyncio.wait_for(port.reader.read(), 5) == b""
