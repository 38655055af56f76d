"""The OPC UA face through node-opcua's client against a real ``serve`` on the simulator:
browse, read, subscribe to a move, every method, the status code of each refusal, encrypted
sessions, refused logins, the audit record and a cut line."""

from __future__ import annotations

import json
from typing import Any

import pytest

from tests.opcua.client import call, node, run_client, run_sessions, session
from tests.support.opcua_cell import OPERATOR, VIEWER, Cell

pytestmark = pytest.mark.asyncio(loop_scope="module")


async def _as_operator(cell: Cell, steps: list[dict[str, Any]], **kw: Any) -> list[Any]:
    answer = await run_client(cell.endpoint, cell.pki, steps, user=OPERATOR[0],
                              password=OPERATOR[1], **kw)  # fmt: skip
    assert answer["connected"] and "error" not in answer, answer
    results: list[Any] = answer["results"]
    return results


async def test_browse_names_from_the_configuration_and_values_with_their_source_time(
    cell: Cell,
) -> None:
    r = await _as_operator(cell, [
        {"op": "browse", "node": node("RC233Gateway")},
        {"op": "browse", "node": node("Loops")},
        {"op": "browse", "node": node("loop:main/Controllers")},
        {"op": "browse", "node": node("main.1/Axes")},
        {"op": "browse", "node": node("main.1.1/ParameterSet")},
        {"op": "browse", "node": node("main.1.1/ActualPosition")},
        {"op": "read", "node": node("main.1.1/ActualPosition")},
        {"op": "read", "node": node("main.1/SoftwareRevision")},
        {"op": "read", "node": node("main.1/Identification/Model")},
        {"op": "read", "node": node("loop:main/LineUp")},
        {"op": "read", "node": node("main.1/Online")},
    ])  # fmt: skip
    assert "Loops" in r[0]["names"]
    assert r[1]["names"] == ["main"]
    assert r[2]["names"] == ["lift", "press"]
    assert r[3]["names"] == ["z", "main.1.2"]  # an axis without a name: its id
    names = set(r[4]["names"])
    assert {"ActualPosition", "ActualPositionPulses", "TargetPosition", "Moving", "Stale",
            "LimitError", "EmergencyError", "CommandError", "StepOutError",
            "Homed"} <= names  # fmt: skip
    assert {"EngineeringUnits", "EURange"} <= set(r[5]["names"])
    position = r[6]
    assert position["status"] == "Good" and position["value"] == 0
    assert position["sourceTimestamp"] is not None  # the reading's time, not the server's
    assert r[7]["status"] == "Good" and r[7]["value"].startswith("1.")
    assert r[8]["value"] == "RC-233"
    assert r[9] == {**r[9], "status": "Good", "value": True}
    assert r[9]["sourceTimestamp"] is not None  # the line's state has a time too
    assert r[10]["value"] is True


async def test_a_move_s_positions_arrive_and_each_method_answers(cell: Cell) -> None:
    pulses = node("main.1.1/ActualPositionPulses")
    r = await _as_operator(cell, [
        {"op": "monitor", "name": "p", "node": pulses},
        {"op": "monitor", "name": "m", "node": node("main.1.1/Moving")},
        # the controller moves: a second motion is a conflict. Sent together, the second runs
        # as soon as the first is accepted (a session's calls keep their order), not a client's
        # round trip later, when on a busy machine a short move could be over already.
        {"op": "parallel", "steps": [
            call("main.1.1", "MoveAbsolute", ("Double", 60), ("String", "user")),
            call("main.1.1", "MoveAbsolute", ("Double", 5), ("String", "user")),
        ]},
        {"op": "await", "name": "p", "value": 6000},
        # at the target, the gateway may not have read yet that it stopped: until it has, a
        # motion is a conflict (on a busy machine the next call came first)
        {"op": "await", "name": "m", "value": False, "latest": True},
        call("main.1.1", "MoveRelative", ("Double", -5), ("String", "user")),
        {"op": "await", "name": "p", "value": 5500},
        {"op": "await", "name": "m", "value": False, "latest": True},
        call("main.1.1", "MoveAbsolute", ("Double", 500), ("String", "user")),
        call("main.1.1", "MoveAbsolute", ("Double", 1.5), ("String", "pulse")),
        call("main.1.1", "MoveAbsolute", ("Double", 1), ("String", "inch")),
        call("main.1.1", "Home", ("String", "0")),
        {"op": "await", "name": "p", "value": 0},
        call("main.1.1", "Stop", ("String", "immediate")),
        call("main.1.1", "AcknowledgeErrors"),
        call("main.1", "Stop", ("String", "")),
        call("loop:main", "Stop", ("String", "decelerate")),
    ])  # fmt: skip
    together, reached, stopped, relative, reached2, stopped2 = r[2:8]
    moved, conflict = together["results"]
    beyond, fraction, unit, home, homed = r[8:13]
    assert stopped["status"] == stopped2["status"] == "Good", (stopped, stopped2)
    assert moved["status"] == "Good" and moved["outputs"][0].startswith("op-")
    assert conflict["status"] == "BadInvalidState"
    assert reached["status"] == "Good", reached
    seen = [s["value"] for s in reached["seen"] if s["status"] == "Good"]
    # positions arrive while it moves, in order, to the target (the reading before the move
    # may be Uncertain on a busy machine: its poll came late, so it is not counted here)
    assert len(seen) >= 2 and seen[0] < 6000 and seen[-1] == 6000 and seen == sorted(seen)
    assert relative["status"] == "Good" and reached2["status"] == "Good"
    assert beyond["status"] == "BadOutOfRange"  # soft_max 100 mm
    assert fraction["status"] == "BadOutOfRange"  # not a whole number of pulses
    assert unit["status"] == "BadInvalidArgument"
    assert home["status"] == "Good" and homed["status"] == "Good"
    stop, ack, ctl_stop, loop_stop = r[13:]
    assert stop == {"status": "Good", "outputs": ["done"]}
    assert ack["status"] == "Good"
    assert ctl_stop == {"status": "Good", "outputs": ["done"]}
    assert loop_stop == {"status": "Good", "outputs": ["done"]}


async def test_a_viewer_reads_but_calls_nothing_and_bad_logins_are_refused(
    cell: Cell,
) -> None:
    viewer, anonymous, wrong, other = await run_sessions([
        session(cell.endpoint, cell.pki, [
            {"op": "read", "node": node("main.1.1/ActualPosition")},
            call("main.1.1", "MoveAbsolute", ("Double", 1), ("String", "user")),
            call("main.1.1", "Stop", ("String", "")),
            call("loop:main", "Stop", ("String", "")),
        ], user=VIEWER[0], password=VIEWER[1]),
        session(cell.endpoint, cell.pki, []),
        session(cell.endpoint, cell.pki, [], user=OPERATOR[0], password="nope"),
        # a token under another token's name
        session(cell.endpoint, cell.pki, [], user=VIEWER[0], password=OPERATOR[1]),
    ])  # fmt: skip
    read, move, stop, loop_stop = viewer["results"]
    assert read["status"] == "Good"
    assert move["status"] == stop["status"] == loop_stop["status"] == "BadUserAccessDenied"
    assert not anonymous["connected"]
    assert "anonymous" in anonymous["error"].lower()
    assert not wrong["connected"] and "denied" in wrong["error"].lower(), wrong
    assert not other["connected"]


async def test_signed_and_encrypted_sessions(cell: Cell) -> None:
    steps = [{"op": "read", "node": node("main.1/Online")}, call("main.1.1", "AcknowledgeErrors")]
    login = {"user": OPERATOR[0], "password": OPERATOR[1]}
    answers = await run_sessions([
        session(cell.endpoint, cell.pki, steps, policy="Basic256Sha256", mode="SignAndEncrypt",
                **login),
        session(cell.endpoint, cell.pki, steps, policy="Aes256_Sha256_RsaPss", mode="Sign",
                **login),
        session(cell.endpoint, cell.pki, steps, policy="Aes256_Sha256_RsaPss",
                mode="SignAndEncrypt", **login),
    ])  # fmt: skip
    for answer in answers:
        assert answer["connected"], answer
        online, ack = answer["results"]
        assert online["status"] == "Good" and online["value"] is True
        assert ack["status"] == "Good"
    # made at the first start, in the state directory
    assert (cell.workdir / "state" / "opcua" / "server-cert.der").is_file()


async def test_local_control_is_bad_invalid_state_and_stops_still_go(cell: Cell) -> None:
    await cell.control(op="input", body="2", bit=0, on=True)
    try:
        r = await _as_operator(cell, [
            {"op": "monitor", "name": "local", "node": node("main.2/LocalControl")},
            {"op": "await", "name": "local", "value": True},
            call("main.2.1", "MoveAbsolute", ("Double", 100), ("String", "pulse")),
            call("main.2.1", "Stop", ("String", "")),
        ])  # fmt: skip
    finally:
        await cell.control(op="input", body="2", bit=0, on=False)
    assert r[1]["status"] == "Good", r[1]
    assert r[2]["status"] == "BadInvalidState"
    assert r[3]["status"] == "Good"  # a stop is never refused


async def test_a_silent_controller_is_bad_no_communication(cell: Cell) -> None:
    position = node("main.2.1/ActualPosition")
    ready = await _as_operator(cell, [{"op": "read", "node": position}])
    assert ready[0]["status"] == "Good"
    await cell.control(op="power", body="2", on=False)
    try:
        r = await _as_operator(cell, [
            {"op": "monitor", "name": "p", "node": position},
            {"op": "monitor", "name": "online", "node": node("main.2/Online")},
            {"op": "await", "name": "p", "status": "BadNoCommunication", "timeout": 30000},
            {"op": "await", "name": "online", "value": False, "timeout": 30000},
            {"op": "read", "node": position},
            call("main.2.1", "MoveAbsolute", ("Double", 10), ("String", "pulse")),
        ])  # fmt: skip
    finally:
        await cell.control(op="power", body="2", on=True)
    silent, offline, read, move = r[2:]
    assert silent["status"] == "Good", silent
    assert offline["status"] == "Good", offline
    # never the last good number: no value, the time of the last reading
    assert read["status"] == "BadNoCommunication" and read["value"] is None
    assert read["sourceTimestamp"] is not None
    assert move["status"] == "BadNoCommunication", move  # offline: nothing sent


async def test_every_call_is_audited_refusals_too(cell: Cell) -> None:
    # (after the tests above: their calls)
    lines = (cell.workdir / "audit.jsonl").read_text().splitlines()
    entries = [json.loads(line) for line in lines]
    opcua = [e for e in entries if e["method"] == "OPCUA"]
    paths = {e["path"] for e in opcua}
    assert {"axes/main.1.1/MoveAbsolute", "axes/main.1.1/Home", "controllers/main.1/Stop",
            "loops/main/Stop"} <= paths  # fmt: skip
    refused = [e for e in opcua if e.get("status") == "BadOutOfRange"]
    assert refused and refused[0]["token"] == "op" and refused[0]["client"] == "opcua"
    assert any(e.get("status") == "BadUserAccessDenied" and e["token"] == "view" for e in opcua)
    # A call that acts was on disk before it acted: its intent, then its outcome naming it.
    by_seq = {e["seq"]: e for e in entries}
    for path in ("axes/main.1.1/MoveAbsolute", "controllers/main.1/Stop"):
        done = [e for e in opcua if e["path"] == path and e.get("status") == "Good"]
        assert done, (path, opcua)
        intent = by_seq[done[0]["intent"]]
        assert (intent["event"], intent["path"]) == ("intent", path), intent
        assert intent["seq"] < done[0]["seq"]
    assert not any(OPERATOR[1] in line or VIEWER[1] in line for line in lines)


async def test_a_cut_line_is_bad_no_communication(cell: Cell) -> None:
    await cell.control(op="cut", cut=True)
    try:
        r = await _as_operator(cell, [
            {"op": "monitor", "name": "up", "node": node("loop:main/LineUp")},
            {"op": "await", "name": "up", "value": False, "timeout": 30000},
            {"op": "read", "node": node("main.1.1/ActualPosition")},
            {"op": "read", "node": node("main.1/Mode")},
            call("main.1.1", "MoveAbsolute", ("Double", 1), ("String", "user")),
        ])  # fmt: skip
    finally:
        await cell.control(op="cut", cut=False)
    assert r[1]["status"] == "Good", r[1]
    assert r[2]["status"] == "BadNoCommunication" and r[2]["value"] is None
    assert r[3]["status"] == "BadNoCommunication"
    assert r[4]["status"] == "BadNoCommunication"
