"""What a running user program prints reaches clients as events, and replies stay replies.

A program shares the line with the host's replies (§11-3, §12 /CO, /CC, /O3; query output
without '>'); docs/manual-notes.md "A program's output and a reply in progress": the simulated
controller sends whole messages, program output first when it was ready first. The gateway must
tell a `/CO` line (`>text` CR) from the `>` of a reply, publish every printed line on its
controller's topic in order, none lost and none invented, and still answer run, status, pause
and stop correctly while the program prints.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable
from typing import Any

import pytest
from websockets.asyncio.client import connect

from gateway.api.app import API_PREFIX
from gateway.service.events import EventKind, ServiceEvent
from gateway.sim.clock import RecordKind
from tests.support.sim_app import WAIT, Api, running_app
from tests.support.ws_server import WsClient, start_uvicorn

PROGRAM = "/controllers/sim.1/program"


@pytest.fixture
async def api() -> AsyncIterator[Api]:
    async with running_app() as running:
        yield running


def printed(api: Api) -> list[ServiceEvent]:
    return [e for e in api.events if e.kind is EventKind.PROGRAM_OUTPUT]


async def until_printed(api: Api, check: Callable[[list[ServiceEvent]], bool]) -> None:
    """Wait (on the gateway's events, no sleeping) until ``check(printed)`` holds."""
    seen = asyncio.Event()
    stop = api.runtime.events.subscribe(lambda _event: seen.set())
    try:
        async with asyncio.timeout(WAIT):
            while not check(printed(api)):
                seen.clear()
                await seen.wait()
    finally:
        stop()


def lines(events: list[ServiceEvent]) -> list[Any]:
    return [(e.topic, e.data["controller"], e.data["data"]) for e in events]


async def test_co_lines_and_query_output_reach_the_controllers_topic_and_run_answers(
    api: Api,
) -> None:
    assert (await api.client.put(PROGRAM, json={"text": "/COHELLO/6/COBYE/END"})).status_code == 200
    r = await api.client.post(f"{PROGRAM}/run")
    assert r.status_code == 200, r.text  # was 504: the HELLO line taken for GSS's '>'
    assert r.json()["results"][1]["form"] == "GSS"
    assert r.json()["results"][1]["value"] in ("1", "0")
    await until_printed(api, lambda got: any(e.data["data"] == "BYE" for e in got))
    topic = "controller:sim.1"
    # /6 prints the selected motor's position (0) as a query reply without '>' (§11-3)
    assert lines(printed(api)) == [
        (topic, "sim.1", "HELLO"),
        (topic, "sim.1", "00000000"),
        (topic, "sim.1", "BYE"),
    ]
    status = await api.client.get(f"{PROGRAM}/status")
    assert status.status_code == 200 and status.json()["state"] == "0"
    assert lines(printed(api))[3:] == []  # nothing invented afterwards (the GSS digit)


async def test_run_status_pause_and_stop_answer_while_a_program_prints(api: Api) -> None:
    # 100 numbered lines, 0.5 s apart (/T5, §12 /T): 50 s of device time, 1 s here.
    text = "".join(f"/COL{n:03d}/T5" for n in range(1, 101)) + "/END"
    assert (await api.client.put(PROGRAM, json={"text": text})).status_code == 200
    r = await api.client.post(f"{PROGRAM}/run")
    assert r.status_code == 200, r.text
    for _ in range(5):
        status = await api.client.get(f"{PROGRAM}/status")
        assert status.status_code == 200, status.text
    r = await api.client.post(f"{PROGRAM}/pause")
    assert r.status_code == 200, r.text
    status = await api.client.get(f"{PROGRAM}/status")
    assert status.status_code == 200 and status.json()["state"] == "P", status.text
    r = await api.client.post(f"{PROGRAM}/resume")
    assert r.status_code == 200, r.text
    for _ in range(3):
        status = await api.client.get(f"{PROGRAM}/status")
        assert status.status_code == 200, status.text
    await until_printed(api, lambda got: any(e.data["data"] == "L100" for e in got))
    r = await api.client.post(f"{PROGRAM}/stop")
    assert r.status_code == 200, r.text
    expected = [("controller:sim.1", "sim.1", f"L{n:03d}") for n in range(1, 101)]
    assert lines(printed(api)) == expected


async def test_a_program_stopped_while_it_prints_loses_no_line(api: Api) -> None:
    # 200 numbered lines 0.5 s apart (/T5): stopped (GE) after the tenth, long before the last
    # even when the host is slow (at 0.1 s apart a busy machine saw all 200 before the stop).
    text = "".join(f"/COT{n:03d}/T5" for n in range(1, 201)) + "/END"
    assert (await api.client.put(PROGRAM, json={"text": text})).status_code == 200
    mark = api.mark()
    assert (await api.client.post(f"{PROGRAM}/run")).status_code == 200
    await until_printed(api, lambda got: len(got) >= 10)
    r = await api.client.post(f"{PROGRAM}/stop")
    assert r.status_code == 200, r.text
    status = await api.client.get(f"{PROGRAM}/status")
    assert status.status_code == 200 and status.json()["state"] == "0"
    # every line the simulator put on the line was published, in order, and nothing else
    sent = [
        r.data.decode()[1:-1]
        for r in api.sim.log.since(mark)
        if r.kind is RecordKind.LATER and r.data.startswith(b">T")
    ]
    assert 10 <= len(sent) < 200
    assert lines(printed(api)) == [("controller:sim.1", "sim.1", text) for text in sent]
    assert sent == [f"T{n:03d}" for n in range(1, len(sent) + 1)]


async def test_a_websocket_client_of_the_controller_gets_every_line_in_order() -> None:
    async with running_app(("1",)) as api:
        server, port = await start_uvicorn(api.app)
        try:
            url = f"ws://127.0.0.1:{port}{API_PREFIX}/ws"
            async with connect(url, compression=None, close_timeout=2) as conn:
                client = WsClient(conn)
                assert (await client.subscribe("controller:gantry"))["type"] == "snapshot"
                text = "".join(f"/COW{n:02d}" for n in range(1, 21)) + "/END"
                assert (await api.client.put(PROGRAM, json={"text": text})).status_code == 200
                assert (await api.client.post(f"{PROGRAM}/run")).status_code == 200
                got: list[dict[str, Any]] = []
                while not got or got[-1]["data"]["data"] != "W20":
                    message = await client.recv()
                    if message["type"] == "event" and message["kind"] == "program_output":
                        got.append(message)
        finally:
            await server.shutdown()
    assert [m["data"]["data"] for m in got] == [f"W{n:02d}" for n in range(1, 21)]
    assert {(m["resource"], m["data"]["controller"]) for m in got} == {
        ("controller:sim.1", "sim.1")
    }
