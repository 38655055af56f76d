"""Program upload (§10 I, §11-3): ``I``, then the text ended by CR, as one transaction."""

from __future__ import annotations

import asyncio

from gateway.bus.requests import Outcome, Priority, ReplyKind
from gateway.protocol.command_text import parse
from gateway.protocol.program import parse_program
from gateway.sim.clock import RecordKind
from gateway.sim.faults import FaultKind
from tests.support.bus_rig import Bus, MakeBus

# Move, wait, move back (§11-4 style); written in 16-byte pieces: several writes.
TEXT = "//22000//3//T10//4//?//T10//5//?//END"


def heard(bus: Bus) -> list[bytes]:
    return [r.data for r in bus.records(RecordKind.HEARD)]


async def test_a_program_upload_is_one_transaction(make_bus: MakeBus) -> None:
    bus = await make_bus("12", upload_chunk=16)
    bus.scheduler.trace.enable()
    program = parse_program(TEXT)
    polls: list[asyncio.Future[object]] = []

    def poll_meanwhile() -> None:
        for body in "12":
            polls.append(
                asyncio.ensure_future(
                    bus.scheduler.submit(body, parse("A000D"), priority=Priority.POLL)
                )
            )

    bus.once_after("I", poll_meanwhile)
    result = await bus.scheduler.upload_program("1", program)
    await asyncio.gather(*polls)
    assert result.outcome is Outcome.DONE
    # Nothing between 'I' and the text's CR: the polls come after it.
    frames = heard(bus)
    start = frames.index(b"$1I\r")
    assert frames[start + 1] == TEXT.encode("ascii") + b"\r"
    assert sorted(frames[start + 2 :]) == [b"$1A000D\r", b"$2A000D\r"]
    sent = [r.data for r in bus.scheduler.trace.records() if r.direction.value == "tx"]
    assert sent[1:][:3] == [b"//22000//3//T10/", b"/4//?//T10//5//?", b"//END\r"]
    stored = await bus.query("1", "IR")
    assert stored == TEXT


async def test_a_lost_reply_to_the_text_is_read_back_with_ir(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    program = parse_program(TEXT)
    bus.once_after("I", lambda: bus.fault(FaultKind.DROP))
    result = await bus.scheduler.upload_program("1", program)
    step = result.results[0]
    assert step.outcome is Outcome.DONE
    assert step.seen["text_reply"] is ReplyKind.TIMEOUT
    assert step.seen["read_back"] == TEXT
    assert heard(bus)[-1] == b"$1IR\r"
    assert heard(bus).count(b"$1I\r") == 1  # never sent again


async def test_a_lost_reply_to_i_still_sends_the_text(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    bus.fault(FaultKind.DROP)
    result = await bus.scheduler.upload_program("1", parse_program(TEXT))
    assert result.outcome is Outcome.DONE  # the '>' to the text shows I was taken
    assert result.results[0].seen["i_reply"] is ReplyKind.TIMEOUT
    assert (await bus.query("1", "IR")) == TEXT
