"""/metrics tells what each gateway process holds: RSS, descriptors, tasks, bounded structures."""

from __future__ import annotations

import asyncio
import os
import subprocess
import sys
import time
from pathlib import Path

from tests.support.exposition import parse_exposition
from tests.support.sim_app import running_app


def _by_role(family: object) -> dict[str, dict[str, float]]:
    out: dict[str, dict[str, float]] = {}
    for (_, labels), number in family.samples.items():  # type: ignore[attr-defined]
        label = dict(labels)
        out.setdefault(label["role"], {})[label["pid"]] = number
    return out


def _status_rss(pid: int) -> int:
    text = Path(f"/proc/{pid}/status").read_text()
    return next(int(line.split()[1]) * 1024 for line in text.splitlines() if "VmRSS:" in line)


async def test_metrics_give_the_api_process_and_its_children() -> None:
    async with running_app() as api:
        # A child as a line worker is one: a process started by the API process.
        spawned = time.time()
        child = subprocess.Popen([sys.executable, "-c", "import sys; sys.stdin.read()"],
                                 stdin=subprocess.PIPE)  # fmt: skip
        try:
            response = await api.client.get("http://localhost/metrics")
            assert response.status_code == 200
            fams = parse_exposition(response.text)
            child_rss = _status_rss(child.pid)
        finally:
            assert child.stdin is not None
            child.stdin.close()
            await asyncio.to_thread(child.wait, 20)
    me = str(os.getpid())
    rss = _by_role(fams["rc233_process_resident_bytes"])
    fds = _by_role(fams["rc233_process_open_fds"])
    assert set(rss) == {"api", "worker"}
    assert list(rss["api"]) == [me]
    assert rss["api"][me] > 20e6  # a Python process with FastAPI loaded
    assert abs(rss["worker"][str(child.pid)] - child_rss) < 4e6
    assert fds["api"][me] >= 3 and fds["worker"][str(child.pid)] >= 3
    started = _by_role(fams["rc233_process_start_time_seconds"])
    assert abs(started["worker"][str(child.pid)] - spawned) < 5
    assert started["api"][me] <= spawned
    tasks = fams["rc233_process_asyncio_tasks"].samples
    assert [dict(labels)["role"] for _, labels in tasks] == ["api"]
    assert next(iter(tasks.values())) >= 1  # this request runs in one
    kept = {dict(labels)["structure"]: v for (_, labels), v in
            fams["rc233_memory_kept_items"].samples.items()}  # fmt: skip
    assert set(kept) == {"audit", "feed_replay"}
    assert kept["feed_replay"] >= 1  # the controllers came online
