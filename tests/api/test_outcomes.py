"""Outcomes resolved, not abandoned: an operation left ``unknown`` because the controller fell
silent is read back when it answers again, and every watcher learns the verdict.
"""

from __future__ import annotations

from typing import Any

from gateway.service.events import EventKind
from gateway.sim.faults import FaultKind, FaultRule
from tests.support.sim_app import Api, running_app


def operation_states(api: Api, ident: str) -> list[str]:
    """The states the operation ``ident`` was published in, in order."""
    return [
        e.data["state"]
        for e in api.events
        if e.kind is EventKind.OPERATION and e.data["id"] == ident
    ]


async def test_an_unknown_move_is_resolved_done_when_the_controller_answers_again() -> None:
    async with running_app() as api:
        await api.identified()
        start = api.position("1", 1)
        move = await api.client.post(
            "/axes/sim.1.1/move", json={"position": 20000, "relative": True, "unit": "pulse"}
        )
        assert move.status_code == 202, move.text
        ident = move.json()["id"]
        # The controller carries out the move but its next replies are lost: the poller
        # marks it offline and the operation cannot be known ...
        api.sim.faults.add(FaultRule(FaultKind.DROP, shots=12, body="1"))
        op = api.operations.get(ident)
        await api.until(lambda: "unknown" in operation_states(api, ident))
        unknown: dict[str, Any] = dict(op.view().model_dump(mode="json"))
        assert unknown["error"]["kind"] in ("offline", "device"), unknown
        # ... until it answers again: read back against the pre-read, it was done.
        await api.until(lambda: op.state.value == "done")
        assert op.position == start + 20000 == api.position("1", 1)
        assert operation_states(api, ident)[-2:] == ["unknown", "done"]
        assert op.error is None
        r = await api.client.get(f"/operations/{ident}")
        assert r.json()["state"] == "done" and r.json()["position"] == start + 20000
        entries = api.services.audit.entries()
        resolved = [e for e in entries if e.get("event") == "operation_resolved"]
        assert resolved and resolved[-1]["operation"]["id"] == ident, entries[-3:]
        assert resolved[-1]["operation"]["state"] == "done"
        assert resolved[-1]["position_after"] == start + 20000
