"""Method calls run beside the session's other requests, in the order they were sent.

asyncua's server handled one connection's requests strictly one after the other, so a motion
call (its audit entry written ahead, the line accepting the motion) held the session's reads,
publishes and keep-alive reads behind it; a client that moved every axis of a 3-loop cell at
once lost its session (its keep-alive read gave up). node-opcua's client sends the requests of
one session at once, without waiting for an answer, and reports the order the answers came in.
"""

from __future__ import annotations

import asyncio
import json
from typing import Any

import pytest
from asyncua import ua
from asyncua.common.utils import Buffer
from asyncua.server.uaprocessor import UaProcessor
from asyncua.ua.ua_binary import nodeid_to_binary, struct_to_binary

from gateway.opcua.call_lanes import install_call_lanes, pending_calls
from tests.opcua.client import call, node, run_client
from tests.support.opcua_cell import OPERATOR, Cell

pytestmark = pytest.mark.asyncio(loop_scope="module")


async def _heard_since(cell: Cell, since: int) -> list[dict[str, Any]]:
    trace: list[dict[str, Any]] = (await cell.control(op="trace", since=since))["trace"]
    return [r for r in trace if r["kind"] == "heard" and r["body"] == "1"]


async def test_a_read_sent_behind_calls_is_answered_before_them_and_the_calls_keep_their_order(
    cell: Cell,
) -> None:
    since = (await cell.control(op="trace"))["trace"][-1]["seq"] + 1
    answer = await run_client(cell.endpoint, cell.pki, [
        {"op": "read", "node": node("main.1.1/ActualPositionPulses")},
        {"op": "parallel", "steps": [
            call("main.1.1", "MoveAbsolute", ("Double", 20), ("String", "user")),
            call("main.1.1", "Stop", ("String", "immediate")),
            {"op": "read", "node": node("loop:main/LineUp")},
        ]},
    ], user=OPERATOR[0], password=OPERATOR[1])  # fmt: skip
    assert answer["connected"] and "error" not in answer, answer
    before, sent = answer["results"]
    assert before["status"] == "Good" and before["value"] == 0
    move, stop, read = sent["results"]
    assert read == {**read, "status": "Good", "value": True}
    # the read did not wait for the calls (each waits for its audit entry and the line)
    assert sent["order"][0] == 2, sent
    # the calls ran in the order sent: the move was accepted, then the stop went out
    assert move["status"] == "Good" and move["outputs"][0].startswith("op-"), move
    assert stop == {"status": "Good", "outputs": ["done"]}
    # on the wire: the target (2 = position data, §10 2), the start (3), then the stop (S)
    frames = [r["data"] for r in await _heard_since(cell, since)]
    assert "$122000\r" in frames and "$13\r" in frames and "$1S\r" in frames, frames
    assert frames.index("$122000\r") < frames.index("$13\r") < frames.index("$1S\r"), frames


async def test_a_stop_overtakes_the_calls_waiting_before_it_and_the_motions_it_covers_are_refused(
    cell: Cell,
) -> None:
    # Sent at once on one session: a move of controller 2 (running when the rest arrive), a
    # move of controller 1, a stop of controller 1's axis, another move of controller 1. The
    # stop waits for the running call only; the move of controller 1 it overtook is refused;
    # the move sent after the stop runs after it.
    since = (await cell.control(op="trace"))["trace"][-1]["seq"] + 1
    answer = await run_client(cell.endpoint, cell.pki, [
        {"op": "parallel", "steps": [
            call("main.2.1", "MoveRelative", ("Double", 5), ("String", "pulse")),
            call("main.1.1", "MoveRelative", ("Double", 5), ("String", "pulse")),
            call("main.1.1", "Stop", ("String", "immediate")),
            call("main.1.1", "MoveRelative", ("Double", 0.05), ("String", "user")),
        ]},
    ], user=OPERATOR[0], password=OPERATOR[1])  # fmt: skip
    assert answer["connected"] and "error" not in answer, answer
    first, overtaken, stop, after = answer["results"][0]["results"]
    assert first["status"] == "Good" and first["outputs"][0].startswith("op-"), first
    assert overtaken["status"] == "BadInvalidState", overtaken
    assert stop == {"status": "Good", "outputs": ["done"]}
    assert after["status"] == "Good" and after["outputs"][0].startswith("op-"), after
    # Controller 1 heard the stop, then the move sent after it (5 pulses, 0.05 mm); nothing
    # of the overtaken one was sent before the stop.
    heard = [r["data"] for r in await _heard_since(cell, since)]
    assert "$1S\r" in heard, heard
    # (2: position data, 3: absolute start, 4: relative start; §10 2, 3, 4)
    moves = [i for i, f in enumerate(heard) if f.startswith(("$12", "$13", "$14"))]
    assert moves and min(moves) > heard.index("$1S\r"), heard
    # The refusal is audited as any refused call: its intent, then its outcome naming why.
    lines = (cell.workdir / "audit.jsonl").read_text().splitlines()
    refused = [
        e for e in map(json.loads, lines)
        if e.get("path") == "axes/main.1.1/MoveRelative" and e.get("status") == "BadInvalidState"
    ]  # fmt: skip
    assert refused and "Stop of main.1.1" in refused[-1]["result"], refused


# ---------------------------------------------------------------- the lane, in process


class _Transport:
    def __init__(self) -> None:
        self.closing = False

    def is_closing(self) -> bool:
        return self.closing

    def close(self) -> None:
        self.closing = True


class _Processor(UaProcessor):  # type: ignore[misc]
    """asyncua's request processor with its service dispatch recorded (and held)."""

    def __init__(self) -> None:
        self._transport = _Transport()
        self.started: list[int] = []
        self.release = asyncio.Event()

    async def _process_message(self, typeid: Any, requesthdr: Any, seqhdr: Any,
                               body: Any) -> bool:  # fmt: skip
        self.started.append(requesthdr.RequestHandle)
        await self.release.wait()
        return True


def _request(object_id: int, handle: int) -> Buffer:
    header = ua.RequestHeader()
    header.RequestHandle = handle
    return Buffer(nodeid_to_binary(ua.NodeId(object_id)) + struct_to_binary(header))


async def _settle() -> None:
    # every lane task of the processor has had its turns (they only wait on each other)
    for _ in range(10):
        await asyncio.sleep(0)


@pytest.mark.asyncio(loop_scope="function")
async def test_calls_return_to_the_request_loop_at_once_and_run_in_order() -> None:
    install_call_lanes()
    processor = _Processor()
    call = ua.ObjectIds.CallRequest_Encoding_DefaultBinary
    assert await processor.process_message(None, _request(call, 1)) is True
    assert await processor.process_message(None, _request(call, 2)) is True
    await _settle()
    assert processor.started == [1]  # the second waits for the first to end
    processor.release.set()
    await asyncio.wait_for(asyncio.gather(*pending_calls()), 5)
    assert processor.started == [1, 2]


@pytest.mark.asyncio(loop_scope="function")
async def test_a_call_whose_connection_closed_before_its_turn_does_not_act() -> None:
    install_call_lanes()
    processor = _Processor()
    call = ua.ObjectIds.CallRequest_Encoding_DefaultBinary
    await processor.process_message(None, _request(call, 1))
    await processor.process_message(None, _request(call, 2))
    await _settle()
    processor._transport.close()  # the client went away while call 1 ran
    processor.release.set()
    await asyncio.wait_for(asyncio.gather(*pending_calls()), 5)
    assert processor.started == [1]


@pytest.mark.asyncio(loop_scope="function")
async def test_other_requests_are_not_put_on_the_lane() -> None:
    install_call_lanes()
    processor = _Processor()
    processor.release.set()
    read = ua.ObjectIds.ReadRequest_Encoding_DefaultBinary
    assert await processor.process_message(None, _request(read, 7)) is True
    assert processor.started == [7] and not pending_calls()
