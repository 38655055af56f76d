"""The control surface: each op as the host on the line sees it, in-process and over TCP."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Callable
from typing import Any

import pytest

from gateway.sim.clock import RecordKind
from gateway.sim.control import Controls, serve_control
from gateway.sim.scene import AxisScene, Scene
from tests.support.sim_wire import Wire

#: A scene the tests rely on: ORG at 0-499, the axis at 30,000 at power-on, limits far away.
SCENE = Scene(AxisScene(ccw_limit=-5000, cw_limit=95000, org_start=0, org_end=499, start=30000))
ORG_BIT = 0x10  # §10 CL: DU bit 4


def op(wire: Wire, **request: Any) -> dict[str, Any]:
    return wire.controls.handle(request)


async def cl_bits(wire: Wire) -> int:
    reply = await wire.exchange(b"$1CL\r")
    assert reply[:3] == b">$1" and reply[-1:] == b"\r", reply
    return int(reply[3:-1], 16)


async def test_state_shows_the_line_and_each_controller(make_wire: Callable[..., Wire]) -> None:
    wire = make_wire("1,2")
    assert await wire.exchange(b"$2OH4000\r") == b">"
    reply = op(wire, op="state")
    assert reply["ok"] is True
    state = reply["state"]
    assert state["baud"] == 9600 and state["cut"] is False and state["host"] is True
    assert [u["name"] for u in state["units"]] == ["1", "2"]
    assert state["units"][1]["controller"]["body"] == "2"


async def test_trace_lists_what_passed(wire: Wire) -> None:
    assert await wire.exchange(b"$1\r") == b">$10\r"
    trace = op(wire, op="trace")["trace"]
    assert [(t["kind"], t["data"]) for t in trace] == [
        ("host", ""),  # the wire's port connected
        ("heard", "$1\r"),
        ("reply", ">$10\r"),
    ]
    assert op(wire, op="trace", since=trace[-1]["seq"] + 1)["trace"] == []


async def test_ems_pressed_sets_the_emergency_flag(wire: Wire) -> None:
    assert op(wire, op="ems", body="1", pressed=True) == {"ok": True}
    assert await wire.exchange(b"$1\r") == b">$14\r"  # §10 "": bit 2
    assert op(wire, op="ems", body="1", pressed=False) == {"ok": True}
    assert await wire.exchange(b"$1\r") == b">$10\r"  # read once, cleared


async def test_a_forced_limit_stops_a_move_with_limit_error(make_wire: Callable[..., Wire]) -> None:
    wire = make_wire(scene=SCENE)
    assert op(wire, op="sensor", body="1", motor=1, sensor="cw_limit", on=True)["ok"]
    assert await wire.exchange(b"$121000\r") == b">"
    assert await wire.exchange(b"$14\r") == b">"  # CW incremental move (§10 4)
    # §8-2 (2): '>$12' = the limit sensor is ON and the motor stopped
    assert await wire.exchange(b"$1\r") == b">$12\r"
    assert await wire.exchange(b"$16\r") == b">$100000000\r"  # no pulse went out
    assert op(wire, op="sensor", body="1", motor=1, sensor="cw_limit", on=None)["ok"]
    assert await wire.exchange(b"$14\r") == b">"
    assert await wire.exchange(b"$1\r") == b">$11\r"  # now it moves
    await wire.wait_idle()
    assert await wire.exchange(b"$16\r") == b">$100001000\r"


async def test_a_forced_sensor_reads_on(make_wire: Callable[..., Wire]) -> None:
    wire = make_wire(scene=SCENE)
    assert not await cl_bits(wire) & ORG_BIT
    op(wire, op="sensor", body="1", motor=1, sensor="org", on=True)
    assert await cl_bits(wire) & ORG_BIT
    op(wire, op="sensor", body="1", motor=1, sensor="org", on=None)
    assert not await cl_bits(wire) & ORG_BIT


async def test_slip_moves_the_mechanics_not_the_counter(make_wire: Callable[..., Wire]) -> None:
    wire = make_wire(scene=SCENE)
    assert op(wire, op="slip", body="1", motor=1, pulses=-29800) == {"ok": True}
    assert await wire.exchange(b"$16\r") == b">$100000000\r"  # the counter did not move
    assert await cl_bits(wire) & ORG_BIT  # but the axis now stands at 200, on ORG


async def test_preset_sets_the_counter_and_is_refused_while_the_motor_moves(
    make_wire: Callable[..., Wire],
) -> None:
    """``preset``: an ``R`` the host did not send; ``R`` is refused while moving (§10 R)."""
    wire = make_wire(scene=SCENE)
    assert op(wire, op="preset", body="1", motor=1, position=1234) == {"ok": True}
    assert await wire.exchange(b"$16\r") == b">$100001234\r"  # the counter, not the mechanics
    assert await wire.exchange(b"$1OL50\r") == b">"
    assert await wire.exchange(b"$1OH100\r") == b">"
    assert await wire.exchange(b"$1290000\r") == b">"
    # 88,766 pulses at 100 pps: about 9 real seconds at the wire's time scale, so the move is
    # still on when the control surface is asked, however busy the machine
    assert await wire.exchange(b"$13\r") == b">"
    refused = op(wire, op="preset", body="1", motor=1, position=5)
    assert refused["ok"] is False and "refused while moving" in refused["error"], refused
    assert await wire.exchange(b"$1S\r") == b">"


async def test_general_input(wire: Wire) -> None:
    assert op(wire, op="input", body="1", bit=0, on=True) == {"ok": True}
    assert await wire.exchange(b"$1C\r") == b">$101\r"  # §10 C: inputs 7-0
    assert op(wire, op="input", body="1", bit=10, on=True)["ok"] is False


async def test_power_off_and_on(wire: Wire) -> None:
    assert await wire.exchange(b"$1OH4000\r") == b">"
    assert op(wire, op="power", body="1", on=False) == {"ok": True}
    assert await wire.exchange(b"$1OH\r") == b""
    assert op(wire, op="power", body="1", on=True) == {"ok": True}
    assert await wire.exchange(b"$1OH\r") == b">$105000\r"  # RAM lost


async def test_power_cycle_with_off_time(wire: Wire) -> None:
    assert op(wire, op="power_cycle", body="1", off_for=0.5) == {"ok": True}
    assert await wire.exchange(b"$1\r") == b""
    on = await wire.loop.log.wait_for(lambda r: r.kind is RecordKind.POWER and r.note == "on", 0, 5)
    off = wire.records(RecordKind.POWER)[0]
    assert on.time - off.time == pytest.approx(0.5)
    assert await wire.exchange(b"$1\r") == b">$10\r"


async def test_body_switch_is_read_at_power_on(make_wire: Callable[..., Wire]) -> None:
    wire = make_wire("1,2")
    assert op(wire, op="switch", body="1", to="2")["ok"] is False  # 2 is taken
    assert op(wire, op="switch", body="1", to="G")["ok"] is False
    assert op(wire, op="switch", body="1", to="3") == {"ok": True}
    assert await wire.exchange(b"$1\r") == b">$10\r"  # not before the power cycle
    op(wire, op="power_cycle", body="1")
    assert await wire.exchange(b"$1\r") == b""
    assert await wire.exchange(b"$3\r") == b">$30\r"
    assert op(wire, op="ems", body="3", pressed=True) == {"ok": True}  # found by its switch
    assert await wire.exchange(b"$3\r") == b">$34\r"


async def test_fault_op_is_a_one_shot_by_default(make_wire: Callable[..., Wire]) -> None:
    wire = make_wire("1,2")
    assert op(wire, op="fault", kind="nak", body="2") == {"ok": True, "rules": 1}
    assert await wire.exchange(b"$1\r") == b">$10\r"
    assert await wire.exchange(b"$2\r") == b"?"
    assert await wire.exchange(b"$2\r") == b">$20\r"


async def test_fault_with_probability_until_cleared(wire: Wire) -> None:
    assert op(wire, op="fault", kind="drop", probability=1.0)["ok"]
    assert await wire.exchange(b"$1\r") == b""
    assert await wire.exchange(b"$1\r") == b""
    assert op(wire, op="clear_faults", kind="drop") == {"ok": True, "removed": 1}
    assert await wire.exchange(b"$1\r") == b">$10\r"


async def test_baud_op_changes_the_line_rate(wire: Wire) -> None:
    assert op(wire, op="baud", baud=1200) == {"ok": True}
    assert await wire.exchange(b"$1\r") == b""  # the controller is still at 9600
    assert op(wire, op="baud", baud=9600) == {"ok": True}
    assert await wire.exchange(b"$19\r") == b">$101\r"  # it heard noise (§10 9 bit 0)
    assert op(wire, op="baud", baud=1234)["ok"] is False


async def test_cut_op(wire: Wire) -> None:
    assert op(wire, op="cut", cut=True, hold=0.2) == {"ok": True}
    restored = await wire.loop.log.wait_for(
        lambda r: r.kind is RecordKind.CUT and r.note == "restored", 0, 5
    )
    assert restored.time - wire.records(RecordKind.CUT)[0].time == pytest.approx(0.2)
    assert await wire.exchange(b"$1\r") == b">$10\r"


def test_bad_requests_are_answered_with_an_error(wire: Wire) -> None:
    assert op(wire, op="nope") == {"ok": False, "error": "unknown op 'nope'"}
    assert op(wire, op="ems", body="9", pressed=True)["ok"] is False  # no such controller
    assert op(wire, op="ems", body="1")["ok"] is False  # missing field
    assert op(wire, op="fault", kind="meteor")["ok"] is False
    assert op(wire, op="fault", kind="nak", colour="red")["ok"] is False
    assert op(wire, op="sensor", body="1", motor=3, sensor="org", on=True)["ok"] is False


async def test_json_lines_over_tcp(wire: Wire) -> None:
    server = await serve_control(Controls(wire.loop), "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        writer.write(b'{"op": "ems", "body": "1", "pressed": true}\nnot json\n[1]\n')
        writer.write(b'{"op": "state"}\n')
        replies = [json.loads(await asyncio.wait_for(reader.readline(), 5)) for _ in range(4)]
        assert replies[0] == {"ok": True}
        assert replies[1]["ok"] is False and replies[1]["error"].startswith("bad request")
        assert replies[2]["ok"] is False
        assert replies[3]["state"]["units"][0]["controller"]["ems"] is True
        assert await wire.exchange(b"$1\r") == b">$14\r"
    finally:
        writer.close()
        server.close()
        await server.wait_closed()
