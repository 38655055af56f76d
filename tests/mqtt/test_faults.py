"""What the plant sees when something fails: EMS, a cut line, a broker restart."""

from __future__ import annotations

import time
from pathlib import Path

from tests.support.mqtt_broker import Broker, Cell, Central

DEVICES = ("gantry", "head", "handler")


async def _ready(central: Central, node: str) -> None:
    """Every controller born and identified (its mode read)."""
    for device in DEVICES:
        await central.identified(node, device)


async def test_ems_on_the_simulator_shows_as_a_latched_error_metric(
    broker: Broker, central: Central, tmp_path: Path
) -> None:
    cell = Cell(broker.port, "ems")
    await cell.start(tmp_path)
    try:
        dbirth = await central.wait_for("DBIRTH", node="ems", device="head")
        assert dbirth.values["Axis/z/Errors/emergency_stop"] is False
        await _ready(central, "ems")
        start = central.mark()
        await cell.control(op="ems", body="2", pressed=True)
        latched = await central.wait_for(
            "DDATA", node="ems", device="head", since=start,
            where=lambda m: m.values.get("Axis/z/Errors/emergency_stop")
            or m.values.get("Axis/theta/Errors/emergency_stop"),
        )  # fmt: skip
        assert latched.payload.metrics[0].timestamp is not None
        # the other controllers show nothing of it
        assert not any(
            "emergency_stop" in name and value
            for m in central.of("ems", start) if m.device != "head"
            for name, value in m.values.items()
        )  # fmt: skip
    finally:
        await cell.stop()


async def test_a_cut_line_gives_each_controller_ddeath_within_2_s_and_dbirth_after(
    broker: Broker, central: Central, tmp_path: Path
) -> None:
    cell = Cell(broker.port, "cut", time_scale=1.0)  # real time: the 2 s are real seconds
    await cell.start(tmp_path)
    try:
        await _ready(central, "cut")
        start = central.mark()
        cut_at = time.time()
        await cell.control(op="cut", cut=True)
        for device in DEVICES:
            death = await central.wait_for("DDEATH", node="cut", device=device, since=start)
            assert death.at - cut_at < 2.0, f"{device}: DDEATH {death.at - cut_at:.2f} s after"
        down = await central.wait_for(
            "NDATA", node="cut", since=start, where=lambda m: m.values.get("Loops/sim/Up") is False
        )
        assert down.values.get("Loops/sim/Cause")
        # no data of a dead controller until it is born again
        back = central.mark()
        await cell.control(op="cut", cut=False)
        for device in DEVICES:
            birth = await central.wait_for("DBIRTH", node="cut", device=device, since=back)
            assert birth.values["Online"] is not False
        between = [m for m in central.of("cut", start)[: back - start] if m.kind == "DDATA"]
        dead_at = {m.device: central.messages.index(m) for m in central.of("cut", start)
                   if m.kind == "DDEATH"}  # fmt: skip
        assert all(central.messages.index(m) < dead_at[m.device] for m in between
                   if m.device in dead_at)  # fmt: skip
    finally:
        await cell.stop()


async def test_a_broker_restart_is_survived_with_a_rebirth(
    broker: Broker, central: Central, tmp_path: Path
) -> None:
    # The central must be back on the new broker before the edge node: the node's first
    # retry after the restart comes 0.5-1 s after its failed one (reconnect_min 1 s).
    cell = Cell(broker.port, "restart", extra={"reconnect_min": 1.0, "reconnect_max": 1.0})
    await cell.start(tmp_path)
    try:
        first = await central.wait_for("NBIRTH", node="restart")
        await central.wait_for("DBIRTH", node="restart", device="handler")
        await central.disconnect()
        await broker.stop()
        start = central.mark()
        await broker.start()
        await central.connect()
        again = await central.wait_for("NBIRTH", node="restart", since=start)
        assert again.payload.seq == 0
        assert again.values["bdSeq"] == (first.values["bdSeq"] + 1) % 256
        for device in DEVICES:
            await central.wait_for("DBIRTH", node="restart", device=device, since=start)
        # and it goes on reporting
        await cell.move("x", 5000)
        await central.wait_for(
            "DDATA", node="restart", device="gantry", since=start,
            where=lambda m: m.values.get("Axis/x/Position") == 5000,
        )  # fmt: skip
    finally:
        await cell.stop()
