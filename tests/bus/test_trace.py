"""The line trace: off until switched on, per loop or per controller; bounded; ASCII or hex."""

from __future__ import annotations

from gateway.bus.trace import FrameDirection, LineTrace
from gateway.protocol.command_text import parse
from tests.support.bus_rig import MakeBus


def test_the_trace_is_off_until_switched_on_and_bounded() -> None:
    trace = LineTrace(size=3)
    trace.add(1.0, FrameDirection.TX, "1", b"$1\r")
    assert trace.records() == []
    trace.enable_body("2")
    trace.add(1.0, FrameDirection.TX, "1", b"$1\r")
    trace.add(2.0, FrameDirection.TX, "2", b"$2\r")
    assert [r.body for r in trace.records()] == ["2"]
    trace.enable()
    for n in range(5):
        trace.add(3.0 + n, FrameDirection.RX, "1", b">$10\r")
    assert len(trace.records()) == 3  # the oldest went first
    record = trace.records()[-1]
    assert record.ascii() == ">$10\\r"
    assert record.hex() == "3e 24 31 30 0d"
    assert record.format() == "7.000000 rx      1 >$10\\r"
    assert record.format(hex_mode=True).endswith("3e 24 31 30 0d")


async def test_the_trace_of_one_controller_on_a_busy_loop(make_bus: MakeBus) -> None:
    bus = await make_bus("12")
    bus.scheduler.trace.enable_body("2")
    await bus.scheduler.submit("1", parse("OH"))
    await bus.scheduler.submit("2", parse("OL"))
    records = bus.scheduler.trace.records()
    assert [(r.direction, r.body, r.data) for r in records] == [
        (FrameDirection.TX, "2", b"$2OL\r"),
        (FrameDirection.RX, "2", b">$200500\r"),
    ]
    assert records[1].time >= records[0].time
