"""Sparkplug ``bdSeq`` goes on across restarts of the gateway process: it is kept in the state
directory, so a host application never sees a new session's birth carry an old session's
number (Sparkplug B 3.0, bdSeq: incremented by one for each new session)."""

from __future__ import annotations

import asyncio
from pathlib import Path

from tests.support.mqtt_broker import WAIT, Broker, Cell, Central


async def test_bdseq_goes_on_after_a_kill_and_after_a_clean_stop(
    broker: Broker, central: Central, tmp_path: Path
) -> None:
    env = {"RC233_STATE_DIR": str(tmp_path / "state")}
    cell = Cell(broker.port, "kept", env=env)
    await cell.start(tmp_path)
    try:
        first = await central.wait_for("NBIRTH", node="kept")
        assert first.values["bdSeq"] == 0  # a new state directory: the first session
        # SIGKILL: the broker sends the will, which carries the session's bdSeq
        mark = central.mark()
        cell.kill()
        death = await central.wait_for("NDEATH", node="kept", since=mark)
        assert death.values["bdSeq"] == 0
        assert cell.process is not None
        await asyncio.wait_for(cell.process.wait(), WAIT)
        await cell.start(tmp_path)
        second = await central.wait_for("NBIRTH", node="kept", since=mark)
        assert second.values["bdSeq"] == 1
        # SIGTERM: a clean NDEATH, and the next process goes on again
        await cell.stop()
        mark = central.mark()
        await cell.start(tmp_path)
        third = await central.wait_for("NBIRTH", node="kept", since=mark)
        assert third.values["bdSeq"] == 2
    finally:
        await cell.stop()
