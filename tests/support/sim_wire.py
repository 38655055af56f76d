"""Fixtures of the simulator tests: ``wire`` (a loop with body 1 and a host port on it).

``Wire.exchange`` sends one frame through the in-process port and returns exactly the bytes of
its reply as the host receives them, after the time they take on the simulated wire (b"" when
no reply comes). Unsolicited messages ($B#*, $B#T ...) that arrive meanwhile are kept in
``Wire.messages`` instead. The loop runs ``SCALE`` times faster than real time.
"""

from __future__ import annotations

import re
from collections.abc import AsyncIterator, Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from gateway.protocol.framing import Series
from gateway.sim.cli import build_loop
from gateway.sim.clock import LineRecord, RecordKind, SimClock
from gateway.sim.control import Controls
from gateway.sim.loop import SimLoop
from gateway.sim.serve import SimPort

#: Time scale of the wire fixture: wire times and motion run this much faster than real time.
SCALE = 100.0
_DELIVERED = (RecordKind.REPLY, RecordKind.LATER, RecordKind.ECHO)


def bodies_of(text: str) -> list[str]:
    """'1', '123' or '1,2,3' -> ['1', '2', '3']."""
    return [b for b in text.split(",")] if "," in text else list(text)


class Wire:
    """A host on an in-process loop that sends a frame and waits for its reply."""

    def __init__(self, loop: SimLoop) -> None:
        self._bind(loop)

    def _bind(self, loop: SimLoop) -> None:
        self.loop = loop
        self.port = SimPort(loop)
        self.controls = Controls(loop)
        self.messages: list[bytes] = []
        self._consumed = loop.log.next_seq

    def fresh(self, bodies: str = "1", **kwargs: Any) -> None:
        """Start over with a new loop of ``bodies`` (same time scale)."""
        scale = self.loop.clock.scale
        self.close()
        self._bind(build_loop(bodies_of(bodies), clock=SimClock(scale), **kwargs))

    def close(self) -> None:
        """Disconnect and stop the loop."""
        self.port.close()
        self.loop.close()

    def send(self, data: bytes) -> None:
        """Write bytes without waiting for anything."""
        self.port.write(data)

    async def exchange(self, frame: bytes, timeout: float = 10.0) -> bytes:
        """Send one frame; its reply as the host gets it (b"" if none comes)."""
        log = self.loop.log
        mark = log.next_seq
        self.port.write(frame)
        heard = await log.wait_for(
            lambda r: r.kind is RecordKind.HEARD and r.ref > 0, mark, timeout
        )
        end = await log.wait_for(
            lambda r: r.ref == heard.ref and r.kind in (RecordKind.REPLY, RecordKind.NONE),
            heard.seq,
            timeout,
        )
        return await self._consume(end)

    async def _consume(self, end: LineRecord) -> bytes:
        """Read from the port every delivery up to ``end``; the bytes of ``end`` if delivered."""
        reply = b""
        for record in list(self.loop.log.since(self._consumed)):
            if record.seq > end.seq:
                break
            if record.kind in _DELIVERED:
                data = await self.port.reader.readexactly(len(record.data))
                assert data == record.data
                if record is end:
                    reply = data
                elif record.kind is RecordKind.ECHO:
                    pass  # inspection mode: the echo is no message
                else:
                    self.messages.append(data)
        self._consumed = end.seq + 1
        return reply

    async def message(self, timeout: float = 10.0) -> bytes:
        """The next unsolicited message (waiting for it if none has come yet)."""
        if not self.messages:
            self.messages.append(await self.delivery(RecordKind.LATER, timeout))
        return self.messages.pop(0)

    async def delivery(self, kind: RecordKind, timeout: float = 10.0) -> bytes:
        """The bytes of the next delivery of ``kind`` (an echo, a message), read from the port."""
        record = await self.loop.log.wait_for(lambda r: r.kind is kind, self._consumed, timeout)
        await self._consume(record)
        return record.data

    async def wait_idle(self, body: str = "1", timeout: float = 30.0) -> None:
        """Poll ``""`` until bit 0 (motor moving) is 0 (§10 "", §13-2 CHECK)."""
        pattern = re.compile(rb"[$#]" + body.encode() + rb"([0-9A-F])")
        loop = self.loop
        deadline = loop.clock.now() + timeout * loop.clock.scale
        while loop.clock.now() < deadline:
            reply = await self.exchange(b"$" + body.encode() + b"\r")
            found = pattern.search(reply)
            if found and not int(found.group(1), 16) & 1:
                return
        raise TimeoutError(f"body {body} still moving after {timeout} s")

    def records(self, kind: RecordKind | None = None) -> list[LineRecord]:
        """Everything the line log still holds (of one kind)."""
        return [r for r in self.loop.log.since(0) if kind is None or r.kind is kind]


def make_loop(
    bodies: str = "1",
    *,
    scale: float = SCALE,
    series: Series = Series.DOLLAR,
    clock: SimClock | None = None,
    **kwargs: Any,
) -> SimLoop:
    """A loop of real controllers (memory-only EEPROM unless ``eeprom_dir`` is given)."""
    clock = clock or SimClock(scale)
    return build_loop(bodies_of(bodies), series=series, clock=clock, **kwargs)


@pytest.fixture
async def wire() -> AsyncIterator[Wire]:
    """Body 1 on an in-process loop at ``SCALE`` times real time."""
    w = Wire(make_loop("1"))
    yield w
    w.close()


@pytest.fixture
async def make_wire() -> AsyncIterator[Callable[..., Wire]]:
    """``make_wire(bodies="1", scale=SCALE, **SimLoop options)`` -> a ``Wire``; closed after."""
    made: list[Wire] = []

    def make(bodies: str = "1", **kwargs: Any) -> Wire:
        w = Wire(make_loop(bodies, **kwargs))
        made.append(w)
        return w

    yield make
    for w in made:
        w.close()


@pytest.fixture
def eeprom_dir(tmp_path: Path) -> Iterator[Path]:
    """A fresh EEPROM directory (the same one = the same controllers after a restart)."""
    path = tmp_path / "eeprom"
    path.mkdir()
    yield path
