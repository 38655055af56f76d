"""The exchange path does no work for a reply that changes nothing, and parses the same.

An idle poll (the same status, again and again) must not copy a state record or arm a timer
per reply: that is the idle gateway's CPU on a 15-controller loop (docs/performance.md).
The parser keeps a line's bytes in bulk rather than one at a time: it must give the same
events as feeding byte by byte, however the bytes are cut into chunks.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest

from gateway.bus import state_records as records_module
from gateway.protocol.command_text import parse
from gateway.protocol.framing import Framing
from gateway.protocol.reply_parser import MAX_LINE, ReplyEvent, ReplyParser
from tests.support.bus_rig import MakeBus


async def test_an_idle_status_poll_copies_no_state_record(
    make_bus: MakeBus, monkeypatch: pytest.MonkeyPatch
) -> None:
    bus = await make_bus("1")
    for _ in range(3):  # the first reads learn the controller: records change then
        await bus.scheduler.submit("1", parse(""))
        await bus.scheduler.submit("1", parse("97"))
    copies: list[Any] = []

    def counted(record: Any, **changes: Any) -> Any:
        copies.append((type(record).__name__, changes))
        return dataclasses.replace(record, **changes)

    monkeypatch.setattr(records_module, "replace", counted)
    for _ in range(5):
        result = await bus.scheduler.submit("1", parse(""))
        assert result.value is not None and not result.value.moving
    assert copies == []
    # The time of the latest reply still reaches a reader (folded in when read).
    cache = bus.scheduler.state_cache
    assert cache.controller(bus.scheduler.name, "1").updated is not None


async def test_a_whole_reply_leaves_no_quiet_timer_armed(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    link = bus.scheduler._link  # the timer is what this test is about
    for _ in range(3):
        await bus.scheduler.submit("1", parse(""))
        assert link._quiet_handle is None


STREAMS = [
    (Framing(), True, b">$1" + b"1234567890" * 3 + b"\r>$1-5\r"),
    (Framing(), False, b">\r$1*\r>@>"),
    (Framing(), True, b">$1ab$1cd\r#1x#\r$1T\r"),
    (Framing(checksum=True), True, b">$112345" + b"00\r"),
    (Framing(echo=True, cr_after_ack=True), True, b"$16\r$1+100\r"),
    (Framing(), True, b">$1" + b"9" * (MAX_LINE + 20) + b"\r"),
]


def _events(framing: Framing, has_data: bool, chunks: list[bytes]) -> list[ReplyEvent]:
    parser = ReplyParser(framing)
    parser.expect("1", b"$16\r", has_data)
    out: list[ReplyEvent] = []
    for chunk in chunks:
        out += parser.feed(chunk)
    return out + parser.line_quiet()


@pytest.mark.parametrize(("framing", "has_data", "stream"), STREAMS)
def test_bulk_parsing_gives_what_byte_by_byte_gives(
    framing: Framing, has_data: bool, stream: bytes
) -> None:
    one_by_one = _events(framing, has_data, [stream[i : i + 1] for i in range(len(stream))])
    assert one_by_one  # every stream here ends at least one message
    for size in (2, 3, 7, len(stream)):
        chunks = [stream[i : i + size] for i in range(0, len(stream), size)]
        assert _events(framing, has_data, chunks) == one_by_one, size
