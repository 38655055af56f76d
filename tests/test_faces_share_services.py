"""The three faces serve the one set of services the composition root built: a lease taken
over REST refuses an OPC UA move, and the DCMDs and OPC UA calls are in the audit record the
REST API serves. Built as ``rc233-gateway serve`` builds them (``compose``, then
``create_app``, ``DeviceCommands.serving`` and ``OpcUaFace`` over the same ``Services``), on
the real app and a simulated loop."""

from __future__ import annotations

from typing import Any

import pytest
from asyncua import ua

from gateway.api.app_services import services_of
from gateway.mqtt.dcmd import DeviceCommands
from gateway.opcua.face import OpcUaFace
from gateway.opcua.methods import StatusRefusal
from gateway.opcua.status_codes import INVALID_STATE
from gateway.opcua.users import _CALLER
from gateway.service.config import OpcUaSettings
from tests.support.sim_app import TOKENS, Api, auth, running_app

TOPIC = "spBv1.0/plant/DCMD/cmd/gantry"


def _opcua(api: Any) -> OpcUaFace:
    book = api.app.state.auth.book
    return OpcUaFace(api.services, OpcUaSettings(), identify=book.principal, state_dir=None)


def _dcmd(api: Any) -> DeviceCommands:
    return DeviceCommands.serving(api.services, api.app.state.auth.book.principal)


def _log_in(face: OpcUaFace, name: str) -> Any:
    """``name``'s OPC UA session making the calls (logged in with the token's name and the
    token, through the face's own user manager)."""
    user = face.users.get_user(None, username=name, password=TOKENS[name][0])
    assert user is not None, f"{name}'s token was not taken"
    return _CALLER.set(user)


async def _audit_entries(api: Api) -> list[dict[str, Any]]:
    page = await api.client.get("/audit", params={"limit": 1000}, headers=auth("admin"))
    assert page.status_code == 200, page.text
    entries: list[dict[str, Any]] = page.json()["entries"]
    return entries


async def test_a_rest_lease_refuses_an_opcua_move_and_every_face_writes_one_audit() -> None:
    async with running_app(roles=True) as api:
        face, dcmd = _opcua(api), _dcmd(api)
        # the very objects: what the app's getters give is what the faces were handed
        request_like = type("Conn", (), {"app": api.app})()
        assert services_of(request_like) is api.services  # type: ignore[arg-type]
        assert face.methods.axes is api.services.axes is dcmd.axes
        assert face.methods.stops is api.services.stops

        taken = await api.client.post("/axes/x/lease", json={"ttl": 60}, headers=auth("alice"))
        assert taken.status_code == 200, taken.text
        before = api.position("1", 1)
        login = _log_in(face, "bob")
        try:
            with pytest.raises(StatusRefusal) as refused:
                await face.methods.move("x", 100, "pulse", relative=False)
        finally:
            _CALLER.reset(login)
        assert refused.value.status == INVALID_STATE
        assert "alice" in str(refused.value)  # the holder REST gave the lease to
        assert api.position("1", 1) == before  # nothing of the refused move was sent

        # the lease holder moves over OPC UA: the lease is alice's in every face
        login = _log_in(face, "alice")
        try:
            operation = await face.methods.move("x", 100, "pulse", relative=False)
        finally:
            _CALLER.reset(login)
        ended = await api.operations.wait(operation, 20)
        assert ended.state.value == "done" and api.position("1", 1) == 100

        # a DCMD stop by bob passes (stops are never refused) and is in the same record
        status, _ = await dcmd.handle(
            TOPIC,
            api.runtime.topology.controller("sim.1"),
            {"x": api.runtime.topology.axis("x").id},
            {"Command/Token": TOKENS["bob"][0], "Axis/x/Stop": True},
        )
        assert status == 200
        entries = await _audit_entries(api)
        methods = [(e["method"], e.get("token"), e.get("status")) for e in entries]
        assert ("OPCUA", "bob", ua.StatusCode(INVALID_STATE).name) in methods
        assert ("OPCUA", "alice", "Good") in methods
        assert ("DCMD", "bob", 200) in methods
        assert any(e["method"] == "POST" and e["path"].endswith("/axes/x/lease") for e in entries)
