"""Operations on disk across versions: a state directory written by the gateway before the
asked models were typed loads, and every operation reads as it did; a stored request that does
not fit its kind is a broken record, refused at load and logged, never served as a 500."""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path
from typing import Any

import pytest

from gateway.service.operations.durable import to_record
from gateway.service.store import StateStore
from gateway.service.store.records import insert_operation
from tests.support.sim_app import json_of, running_app

#: The record text the state store held before (``json.dumps`` of the record dict), and the
#: view clients were answered with then: one operation of each kind, ended. The times are
#: filled in (``_dated``) with ones inside the store's retention of 7 days.
_COMMON = (
    '"motor": 1, "target": 1250, "holder": "mes", "prefix": "$", "state": "done", '
    '"position": 1250, "error": null, "frames": ["$12500", "$13"], "created": @T0@, '
    '"sent": @T1@, "ended": @T2@, "updated": @T2@, "step": null, '
    '"position_before": 0, "stop_requested": false}'
)
STORED = {
    41: '{"id": "op-41-00000001", "axis": "sim.1.1", "kind": "move", "request": '
    '{"position": 12.5, "relative": false, "unit": "user"}, ' + _COMMON,
    42: '{"id": "op-42-00000001", "axis": "sim.1.1", "kind": "jog", "request": '
    '{"direction": "ccw", "speed": "high"}, ' + _COMMON,
    43: '{"id": "op-43-00000001", "axis": "sim.1.1", "kind": "home", "request": '
    '{"method": "0R"}, ' + _COMMON,
    44: '{"id": "op-44-00000001", "axis": "sim.1.1", "kind": "step", "request": '
    '{"direction": "cw"}, ' + _COMMON,
}
_VIEW_COMMON = (
    '"state":"done","target":1250,"target_user":12.5,"position":1250,"position_user":12.5,'
    '"unit":"mm","units":{"target":"pulse","target_user":"mm","position":"pulse",'
    '"position_user":"mm"},"error":null,"frames":["$12500","$13"],"holder":"mes",'
    '"created":@T0@,"sent":@T1@,"ended":@T2@,"updated":@T2@}'
)
ANSWERED = {
    41: '{"id":"op-41-00000001","axis":"sim.1.1","axis_name":"x","kind":"move","request":'
    '{"position":12.5,"relative":false,"unit":"user"},' + _VIEW_COMMON,
    42: '{"id":"op-42-00000001","axis":"sim.1.1","axis_name":"x","kind":"jog","request":'
    '{"direction":"ccw","speed":"high"},' + _VIEW_COMMON,
    43: '{"id":"op-43-00000001","axis":"sim.1.1","axis_name":"x","kind":"home","request":'
    '{"method":"0R"},' + _VIEW_COMMON,
    44: '{"id":"op-44-00000001","axis":"sim.1.1","axis_name":"x","kind":"step","request":'
    '{"direction":"cw"},' + _VIEW_COMMON,
}


#: a minute ago, once for the module: a record and its view carry the same times
_NOW = float(int(time.time())) - 60


def _dated(text: str) -> str:
    now = _NOW
    times = {"@T0@": now + 0.25, "@T1@": now + 0.5, "@T2@": now + 1.75}
    for mark, value in times.items():
        text = text.replace(mark, repr(value))
    return text


async def _state_dir(tmp_path: Path, records: dict[int, str]) -> StateStore:
    """A state directory holding ``records`` (number -> stored JSON text), reopened."""
    store = await StateStore.open(tmp_path / "state")
    for number, text in records.items():
        record: dict[str, Any] = json.loads(_dated(text))
        await store.run(lambda c, n=number, r=record: insert_operation(c, n, r, None))
    await store.close()
    return await StateStore.open(tmp_path / "state")


async def test_operations_stored_before_load_and_read_as_they_did(tmp_path: Path) -> None:
    store = await _state_dir(tmp_path, STORED)
    async with running_app(("1",), store=store) as api:
        for number, answered in ANSWERED.items():
            ident = f"op-{number}-00000001"
            r = await api.client.get(f"/operations/{ident}")
            assert r.status_code == 200, r.text
            assert json_of(r) == json.loads(_dated(answered))
            op = api.operations.get(ident)
            # written back in the shape it was read in: an older gateway reads it too
            assert to_record(op) == json.loads(_dated(STORED[number]))
        listed = json_of(await api.client.get("/operations?axis=x"))
        assert {o["id"]: o["request"] for o in listed} == {
            json.loads(_dated(a))["id"]: json.loads(_dated(a))["request"] for a in ANSWERED.values()
        }


async def test_a_stored_request_that_does_not_fit_its_kind_is_not_loaded(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # a jog whose request lacks its speed (a step's): no operation of the gateway's shape
    broken = STORED[42].replace('"speed": "high"', '"unit": "user"').replace("op-42", "op-45")
    store = await _state_dir(tmp_path, {41: STORED[41], 45: broken})
    caplog.set_level(logging.ERROR, "gateway.service")
    async with running_app(("1",), store=store) as api:
        r = await api.client.get("/operations/op-45-00000001")
        assert r.status_code == 404, r.text
        assert json_of(r)["type"].endswith("not-found")
        assert (await api.client.get("/operations/op-41-00000001")).status_code == 200
        listed = json_of(await api.client.get("/operations"))
        assert [o["id"] for o in listed] == ["op-41-00000001"]
    assert "op-45-00000001: its request does not fit its kind 'jog'" in caplog.text
