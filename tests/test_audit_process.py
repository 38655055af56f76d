"""The audit record of a real ``rc233-gateway serve`` process, killed and starved of disk.

* SIGKILL in the middle of a ``?wait=true`` move, then a restart: the move's entry, written
  ahead, is in the file; the sequence goes on; ``rc233-gateway audit verify`` passes.
* A full disk (a file-size limit, ``RLIMIT_FSIZE``, with ``SIGXFSZ`` ignored so that
  ``write()`` answers ``EFBIG`` the way it answers ``ENOSPC`` on a full filesystem): a move
  is refused ``503`` with ``Retry-After`` and nothing goes on the wire (the line trace), a
  stop still passes; when space returns (the limit raised from outside) ``/readyz`` comes
  back by itself, and no line of the file is glued onto another.
"""

from __future__ import annotations

import asyncio
import json
import os
import resource
import signal
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import httpx

from gateway.cli import main
from gateway.service.audit import ChainFile
from tests.support.serve_process import GATEWAY, free_port
from tests.support.sim_app import DECLARE_JSON

#: Real seconds to wait for the process (a busy machine with two cores)
WAIT = 25.0
#: a move this long (pulses, inside the soft limits) takes seconds at the time scale below
FAR = 90_000


@asynccontextmanager
async def gateway_process(
    tmp_path: Path, audit: Path, *, preexec: Callable[[], None] | None = None
) -> AsyncIterator[tuple[asyncio.subprocess.Process, str]]:
    """``serve --simulate --no-auth`` with ``audit`` as its audit log; (process, API base)."""
    port = free_port()
    env = {**os.environ, "XDG_DATA_HOME": str(tmp_path), "RC233_AUDIT_LOG": str(audit)}
    process = await asyncio.create_subprocess_exec(
        str(GATEWAY), "serve", "--simulate", "--no-auth", "--time-scale", "2",
        "--eeprom-dir", str(tmp_path / "eeprom"), "--port", str(port),
        stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE, env=env,
        preexec_fn=preexec,
    )  # fmt: skip
    assert process.stderr is not None
    log: list[str] = []
    try:
        async with asyncio.timeout(WAIT):
            while not any("Uvicorn running on" in line for line in log):
                line = await process.stderr.readline()
                assert line, "".join(log)
                log.append(line.decode(errors="replace"))
        drain = asyncio.create_task(process.stderr.read())  # a full pipe would stall it
        yield process, f"http://127.0.0.1:{port}"
    finally:
        if process.returncode is None:
            process.kill()
        await asyncio.wait_for(process.wait(), WAIT)
    await asyncio.wait_for(drain, WAIT)


async def _until(check: Callable[[], Any], what: str) -> None:
    """Re-check ``check`` until it holds (the other process gives no event to wait on)."""
    async with asyncio.timeout(WAIT):
        while not await check():
            await asyncio.sleep(0.05)
    assert await check(), what


def _entries(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_bytes().splitlines()]


async def test_a_move_killed_mid_way_is_in_the_file_and_the_sequence_goes_on(tmp_path: Path):
    audit = tmp_path / "audit.jsonl"
    async with (
        gateway_process(tmp_path, audit) as (process, url),
        httpx.AsyncClient(
            base_url=url + "/api/v1", timeout=WAIT, event_hooks=DECLARE_JSON
        ) as client,
    ):
        move = asyncio.create_task(
            client.post("/axes/x/move?wait=true", json={"position": FAR, "unit": "pulse"})
        )

        async def moving() -> bool:
            state = (await client.get("/axes/x")).json()
            return bool(state.get("moving")) or state.get("state") == "moving"

        await _until(moving, "the axis moves")
        process.send_signal(signal.SIGKILL)  # no shutdown: nothing is flushed at exit
        await process.wait()
        move.cancel()
        await asyncio.gather(move, return_exceptions=True)
    before = _entries(audit)
    [intent] = [e for e in before if e["path"] == "/api/v1/axes/x/move"]
    assert intent["event"] == "intent" and intent["body"] == {"position": FAR, "unit": "pulse"}
    assert intent["query"] == "wait=true"
    assert [e["seq"] for e in before] == list(range(1, len(before) + 1))
    async with (
        gateway_process(tmp_path, audit) as (_, url),
        httpx.AsyncClient(
            base_url=url + "/api/v1", timeout=WAIT, event_hooks=DECLARE_JSON
        ) as client,
    ):
        stop = await client.post("/axes/x/stop")
        assert stop.status_code == 200, stop.text
        page = (await client.get("/audit?limit=5")).json()
        assert page["last_seq"] > before[-1]["seq"]
    after = _entries(audit)
    assert [e["seq"] for e in after] == list(range(1, len(after) + 1))  # not [1, 2, 1, 2]
    assert after[: len(before)] == before
    assert main(["audit", "verify", str(audit)]) == 0


def _limited(size: int) -> Callable[[], None]:
    def limit() -> None:  # in the child, before exec
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # write() answers EFBIG instead
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, resource.RLIM_INFINITY))

    return limit


def _prefill(audit: Path, size: int) -> None:
    """A valid history up to ``size`` bytes: the next lines find the disk full."""
    chain = ChainFile(audit)
    i = 0
    while (audit.stat().st_size if audit.exists() else 0) < size:
        chain.append({"time": "t", "method": "POST", "path": f"/old/{i}"}, fsync=False)
        i += 1
    chain.close()


async def test_a_full_disk_refuses_motion_and_readiness_comes_back_by_itself(tmp_path: Path):
    audit = tmp_path / "audit.jsonl"
    limit = 1024 * 1024  # room for what else the process writes; the audit file is near it
    _prefill(audit, limit - 3000)
    async with (
        gateway_process(tmp_path, audit, preexec=_limited(limit)) as (process, url),
        httpx.AsyncClient(base_url=url, timeout=WAIT, event_hooks=DECLARE_JSON) as client,
    ):
        api = "/api/v1"
        trace = await client.put(
            f"{api}/loops/sim/trace", json={"enabled": True, "hex": False, "controllers": []}
        )
        assert trace.status_code == 200, trace.text
        refused = None
        for _ in range(50):  # each request's entries take the last bytes
            r = await client.post(f"{api}/axes/x/move", json={"position": 4321, "unit": "pulse"})
            if r.status_code == 503:
                refused = r
                break
            assert r.status_code in (202, 409), r.text  # 409: still stopping from the last
            await client.post(f"{api}/axes/x/stop")
        assert refused is not None, "the audit file never filled"
        assert refused.headers["Retry-After"] == "1"
        assert refused.json()["field"] == "audit"
        mark = len((await client.get(f"{api}/loops/sim/trace")).json()["lines"])
        again = await client.post(f"{api}/axes/x/move", json={"position": 8765, "unit": "pulse"})
        assert again.status_code == 503
        stop = await client.post(f"{api}/axes/x/stop")  # a stop always passes
        assert stop.status_code == 200, stop.text
        lines = (await client.get(f"{api}/loops/sim/trace")).json()["lines"][mark:]
        sent = [line["text"] for line in lines if line["direction"] == "tx"]
        assert not any("8765" in text for text in sent), sent  # the move never went out
        assert (await client.get("/readyz")).status_code == 503
        # Space returns: the limit lifted from outside, no request in between.
        resource.prlimit(
            process.pid, resource.RLIMIT_FSIZE, (resource.RLIM_INFINITY, resource.RLIM_INFINITY)
        )

        async def ready() -> bool:
            return (await client.get("/readyz")).status_code == 200

        await _until(ready, "/readyz recovers by itself")
        ok = await client.post(f"{api}/axes/x/move", json={"position": 10, "unit": "pulse"})
        assert ok.status_code in (202, 409), ok.text  # not refused for its entry
    entries = _entries(audit)  # every line whole JSON: nothing torn, nothing glued
    assert [e["seq"] for e in entries] == list(range(1, len(entries) + 1))
    assert any(e.get("event") == "audit_resumed" for e in entries)
    late = [e for e in entries if e["path"] == "/api/v1/axes/x/stop" and e.get("late")]
    assert late, "the stop made while the disk was full is recorded once it took writes"
    assert main(["audit", "verify", str(audit)]) == 0
