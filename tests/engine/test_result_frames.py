"""A transaction's result carries the frames it wrote, and they cross a line worker's channel
with it: with SUM1 on (§10 SUM), each with its checksum, as the simulator heard it."""

from __future__ import annotations

from gateway.bus.requests import Outcome
from gateway.protocol.command_text import parse
from gateway.protocol.framing import checksum
from tests.support.bus_rig import MakeBus
from tests.support.engine_rig import Attach


def summed(text: str) -> str:
    """``text`` as a SUM1 frame without its CR: the two hex digits of its byte sum added."""
    return text + checksum(text.encode("ascii")).decode("ascii")


async def test_a_result_across_the_worker_carries_the_frames_written_with_their_checksum(
    make_bus: MakeBus, attach: Attach
) -> None:
    bus = await make_bus("1")
    linked = await attach(bus)
    proxy = linked.client.proxies[bus.scheduler.name]
    assert (await proxy.submit("1", parse("SUM1"))).outcome is Outcome.DONE
    result = await proxy.submit("1", [parse("OH4000"), parse("OL200")], motor=1)
    assert result.outcome is Outcome.DONE
    # §10 SUM: the checksum of '$1OH4000' is the low byte of its byte sum, in hex
    assert result.frames == [summed("$1OH4000"), summed("$1OL200")]
    heard = [f.rstrip(b"\r").decode("ascii") for f in bus.frames("1")]
    assert heard[-2:] == result.frames  # what the line carried, not the models' text again
