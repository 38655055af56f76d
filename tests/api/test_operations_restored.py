"""Operations the last process left: read back from the state store at start, and an operation
that had not ended judged by reading its axis back; a motion that cannot be recorded is
refused before it is sent."""

from __future__ import annotations

import asyncio
import logging
import sqlite3
import threading
from pathlib import Path
from typing import Any

import pytest

from gateway.service.operations import durable
from gateway.service.operations.asked import asked_of
from gateway.service.operations.durable import to_record
from gateway.service.operations.types import Operation, OperationState
from gateway.service.runtime.simulated import simulated_config
from gateway.service.store import StateStore
from gateway.service.store.records import insert_operation, load_operations
from gateway.service.topology import Topology
from tests.support.sim_app import json_of, running_app

WAIT = 20.0


async def _left_behind(tmp_path: Path, number: int, **fields: Any) -> StateStore:
    """A state directory holding operation ``op-<number>`` as a killed gateway left it."""
    store = await StateStore.open(tmp_path / "state")
    axis = Topology(simulated_config()).axis(fields.pop("axis", "x"))
    asked = asked_of(fields.pop("kind"), fields.pop("request"))
    op = Operation(id=f"op-{number}-00000001", axis=axis, asked=asked, motor=axis.motor,
                   holder="mes", commands=(), **fields)  # fmt: skip
    record = to_record(op)
    await store.run(lambda c: insert_operation(c, number, record, None))
    await store.close()
    return await StateStore.open(tmp_path / "state")


async def test_a_move_the_axis_finished_is_done_after_the_restart(tmp_path: Path) -> None:
    # relative -500 from 500: the simulated axis stands at 0, the move's end
    store = await _left_behind(
        tmp_path, 7, kind="move", request={"position": -500, "relative": True, "unit": "pulse"},
        target=0, step=-500, position_before=500, state=OperationState.MOVING,
        frames=["$1F1", "$12-500", "$13"],
    )  # fmt: skip
    async with running_app(store=store) as api:
        op = await api.operations.wait("op-7-00000001", WAIT)
        assert op.state is OperationState.DONE and op.position == 0 and op.error is None
        view = json_of(await api.client.get("/operations/op-7-00000001"))
        assert view["state"] == "done" and view["frames"] == ["$1F1", "$12-500", "$13"]
        # the numbers go on from the last process's: no id comes back
        new = await api.client.post(
            "/axes/x/move?wait=true", json={"position": 10, "unit": "pulse"}
        )
        assert json_of(new)["id"].startswith("op-8-")


async def test_a_move_that_never_left_its_start_is_not_done(tmp_path: Path) -> None:
    store = await _left_behind(
        tmp_path, 3, kind="move", request={"position": 2000, "relative": False, "unit": "pulse"},
        target=2000, position_before=0, state=OperationState.SENT,
    )  # fmt: skip
    async with running_app(store=store) as api:
        op = await api.operations.wait("op-3-00000001", WAIT)
        assert op.state is OperationState.FAILED and op.position == 0
        assert op.error is not None and op.error.outcome == "not_done"
        assert op.error.kind == "restart" and "where it started" in op.error.detail


async def test_a_move_that_stopped_elsewhere_is_unknown_with_what_was_seen(
    tmp_path: Path,
) -> None:
    store = await _left_behind(
        tmp_path, 4, kind="move", request={"position": 2000, "relative": False, "unit": "pulse"},
        target=2000, position_before=100, state=OperationState.MOVING,
    )  # fmt: skip
    async with running_app(store=store) as api:
        op = await api.operations.wait("op-4-00000001", WAIT)
        assert op.state is OperationState.UNKNOWN and op.position == 0
        assert op.error is not None and op.error.outcome == "unknown"
        assert "0 pulses" in op.error.detail and "neither its end 2000" in op.error.detail


async def test_a_jog_left_in_flight_is_stopped_with_ss_and_failed_where_it_stood(
    tmp_path: Path,
) -> None:
    store = await _left_behind(
        tmp_path, 5, kind="jog", request={"direction": "cw", "speed": "low"},
        target=None, state=OperationState.MOVING, frames=["$17"],
    )  # fmt: skip
    async with running_app(store=store) as api:
        op = await api.operations.wait("op-5-00000001", WAIT)
        assert api.heard().count("SS") == 1 and "S" not in api.heard()  # §10 SS, not S
        assert op.state is OperationState.FAILED and op.position == api.position() == 0
        assert op.error is not None and op.error.kind == "restart"
        assert op.error.outcome == "not_done" and "$1SS" in op.error.detail
        entries = json_of(await api.client.get("/audit"))["entries"]
        stops = [e for e in entries if e.get("event") == "restart_stop"]
        assert [(s["bytes_sent"], s["result"], s["token"]) for s in stops] == [
            (["$1SS"], "done", "mes")
        ]


async def test_a_jog_to_a_soft_limit_found_at_it_is_done(tmp_path: Path) -> None:
    # A jog toward a soft limit is a move to it (target = the limit): arrived before the stop.
    store = await _left_behind(
        tmp_path, 6, kind="jog", request={"direction": "ccw", "speed": "low"},
        target=0, state=OperationState.MOVING,
    )  # fmt: skip
    async with running_app(store=store) as api:
        op = await api.operations.wait("op-6-00000001", WAIT)
        assert api.heard().count("SS") == 1
        assert op.state is OperationState.DONE and op.position == 0 and op.error is None


async def test_a_jog_whose_stop_is_never_answered_is_unknown_and_may_still_move(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    # Controller 3 is configured but silent (not on the simulated loop): the stop is tried
    # until the read-back gives up (shortened here), and nobody claims the axis stopped.
    monkeypatch.setattr(durable, "RESTART_READ_BACK", 1.0)
    store = await _left_behind(
        tmp_path, 9, axis="conveyor", kind="jog", request={"direction": "cw", "speed": "low"},
        target=None, state=OperationState.MOVING,
    )  # fmt: skip
    caplog.set_level(logging.ERROR, "gateway.service")
    async with running_app(("1", "2"), config=simulated_config(), store=store) as api:
        op = await api.operations.wait("op-9-00000001", WAIT)
        assert op.state is OperationState.UNKNOWN and op.position is None
        assert op.error is not None and "may still be moving" in op.error.detail
        entries = json_of(await api.client.get("/audit"))["entries"]
        stops = [e for e in entries if e.get("event") == "restart_stop"]
        assert len(stops) == 1 and stops[0]["result"] != "done" and stops[0]["error"], stops
    assert "could not be stopped" in caplog.text, caplog.text


async def test_a_home_left_in_flight_is_not_stopped(tmp_path: Path) -> None:
    # An origin search ends by itself (the origin, or a limit sensor): it is only judged.
    store = await _left_behind(
        tmp_path, 8, kind="home", request={"method": "0R"}, target=0,
        state=OperationState.MOVING,
    )  # fmt: skip
    async with running_app(store=store) as api:
        op = await api.operations.wait("op-8-00000001", WAIT)
        assert op.state is OperationState.DONE and op.position == 0  # the origin, its end
        assert "SS" not in api.heard() and "S" not in api.heard()


async def test_a_motion_that_cannot_be_recorded_is_refused_and_not_sent() -> None:
    async with running_app() as api:
        store = api.runtime.store

        def full(connection: sqlite3.Connection) -> None:
            # The database may grow no more, and its last page is filled: SQLITE_FULL from
            # here on, as on a full disk.
            pages = connection.execute("PRAGMA page_count").fetchone()[0]
            connection.execute(f"PRAGMA max_page_count = {pages}")
            with pytest.raises(sqlite3.OperationalError, match="full"):
                for n in range(10_000):
                    connection.execute("INSERT INTO counters VALUES (?, ?)", (f"filler-{n}", n))

        await store.run(full)
        mark = api.mark()
        r = await api.client.post("/axes/x/move", json={"position": 1500, "unit": "pulse"})
        assert r.status_code == 503, r.text
        assert r.headers["retry-after"] == "5"
        problem = json_of(r)
        assert problem["outcome"] == "not_done" and "nothing was sent" in problem["detail"]
        assert [t for t in api.heard("1", mark) if t.startswith(("2", "3"))] == []  # §10 2, 3
        assert api.position("1", 1) == 0
        assert api.operations.active("sim", "1") is None  # the controller is free again


async def test_a_request_gone_before_its_record_is_written_sends_nothing() -> None:
    async with running_app() as api:
        store = api.runtime.store
        disk = threading.Event()
        store.post(lambda _c: disk.wait(WAIT))  # a slow disk: the store's thread is held
        mark = api.mark()
        request = asyncio.ensure_future(
            api.client.post("/axes/x/move", json={"position": 1500, "unit": "pulse"})
        )
        async with asyncio.timeout(WAIT):
            while api.operations.active("sim", "1") is None:
                await asyncio.sleep(0)  # a turn of the loop, no time: the request runs up to
                # the write of its record, where it waits for the disk
        op = api.operations.active("sim", "1")
        assert op is not None
        request.cancel()
        with pytest.raises(asyncio.CancelledError):
            await request
        disk.set()
        await store.drain()
        assert api.operations.active("sim", "1") is None  # the controller is free again
        assert op.state is OperationState.FAILED and op.error is not None
        assert "nothing was sent" in op.error.detail
        assert [t for t in api.heard("1", mark) if t.startswith(("2", "3"))] == []
        (stored,) = await store.run(lambda c: load_operations(c, 10))
        assert stored["id"] == op.id and stored["state"] == "failed"
        moved = await api.client.post(
            "/axes/x/move?wait=true", json={"position": 10, "unit": "pulse"}
        )
        assert moved.status_code == 200
