"""The edge node of a gateway process on a real mosquitto, seen by an independent decoder."""

from __future__ import annotations

import time
from pathlib import Path

from tests.support.mqtt_broker import Broker, Cell, Central, metric

DEVICES = {"gantry": ("x", "y"), "head": ("z", "theta"), "handler": ("gripper", "conveyor")}
CONTROLLER_METRICS = (
    "Online", "Mode", "Version", "Program", "Moving", "Errors/communication_error",
    "Errors/program_error",
)  # fmt: skip
NODE_METRICS = (
    "bdSeq", "Node Control/Rebirth", "Properties/Version", "Loops/sim/Up", "Loops/sim/Cause",
    "Loops/sim/Line Utilisation", "Loops/sim/Queue Depth", "Loops/sim/Transactions",
    "Loops/sim/Retries", "Loops/sim/Timeouts", "Loops/sim/Busy Seconds",
)  # fmt: skip
AXIS_METRICS = (
    "Position", "Position User", "Target", "Moving", "Stale", "Errors/limit_error",
    "Errors/emergency_stop", "Errors/command_error", "Errors/step_out", "Soft Min", "Soft Max",
    "Homed", "Counter",
)  # fmt: skip


async def test_births_carry_every_metric_and_ddata_follows_a_move(
    broker: Broker, central: Central, tmp_path: Path
) -> None:
    cell = Cell(broker.port, "cell1")
    await cell.start(tmp_path)
    try:
        nbirth = await central.wait_for("NBIRTH", node="cell1")
        assert nbirth.payload.seq == 0
        for name in NODE_METRICS:
            metric(nbirth, name)
        assert nbirth.values["Node Control/Rebirth"] is False
        aliases = [m.alias for m in nbirth.payload.metrics]
        for device, axes in DEVICES.items():
            birth = await central.wait_for("DBIRTH", node="cell1", device=device)
            for name in CONTROLLER_METRICS:
                metric(birth, name)
            for axis in axes:
                for name in AXIS_METRICS:
                    metric(birth, f"Axis/{axis}/{name}")
            assert "Axis/x/Stop" not in birth.values  # DCMD off by default
            aliases += [m.alias for m in birth.payload.metrics]
        # one alias per metric across the node and its devices (Sparkplug 3.0 6.4.2)
        assert None not in aliases and len(set(aliases)) == len(aliases)
        dbirth = await central.wait_for("DBIRTH", node="cell1", device="gantry")
        assert metric(dbirth, "Axis/x/Position User").properties == {"engUnit": "mm"}
        assert dbirth.values["Axis/x/Soft Max"] == 940.0
        assert dbirth.values["Axis/x/Homed"] is False  # at start the origin is not known
        # once read, the device's values are there (report by exception: the DDATA that
        # follow the birth carry only what moved)
        await central.wait_for(
            "DDATA", device="gantry", where=lambda m: m.values.get("Axis/x/Position") == 0
        )
        await central.identified("cell1", "handler")
        start = central.mark()
        await cell.move("x", 20000)
        moving = await central.wait_for(
            "DDATA", device="gantry", since=start, where=lambda m: m.values.get("Axis/x/Moving")
        )
        end = await central.wait_for(
            "DDATA", device="gantry", since=start,
            where=lambda m: m.values.get("Axis/x/Moving") is False,
        )  # fmt: skip
        # the last position read may follow the end of the motion (or come with it)
        await central.wait_for(
            "DDATA", device="gantry", since=start,
            where=lambda m: m.values.get("Axis/x/Position") == 20000,
        )  # fmt: skip
        positions = [
            m.values["Axis/x/Position"]
            for m in central.messages[start:]
            if m.device == "gantry" and "Axis/x/Position" in m.values
            and m.values["Axis/x/Position"] is not None
        ]  # fmt: skip
        assert positions == sorted(positions), positions
        assert len(positions) >= 3 and positions[-1] == 20000, positions
        assert central.messages.index(moving) < central.messages.index(end)
        # only what changed: no DDATA repeats the soft limits or the version
        assert all("Axis/x/Soft Max" not in m.values for m in central.of("cell1", start))
        # the device's timestamps: each position's time is when it was read, not later
        for m in central.of("cell1", start):
            for d in m.payload.metrics:
                assert d.timestamp is not None and d.timestamp <= m.at * 1000 + 1
    finally:
        await cell.stop()
    death = await central.wait_for("NDEATH", node="cell1")
    assert death.values["bdSeq"] == nbirth.values["bdSeq"]


async def test_killed_gateway_gets_ndeath_with_the_birth_bdseq_and_rebirth_on_ncmd(
    broker: Broker, central: Central, tmp_path: Path
) -> None:
    from tests.mqtt.sparkplug_decoder import command

    cell = Cell(broker.port, "cell2")
    await cell.start(tmp_path)
    try:
        nbirth = await central.wait_for("NBIRTH", node="cell2")
        await central.wait_for("DBIRTH", node="cell2", device="handler")
        start = central.mark()
        ncmd = command(int(time.time() * 1000), {"Node Control/Rebirth": True})
        await central.publish("spBv1.0/plant/NCMD/cell2", ncmd)
        again = await central.wait_for("NBIRTH", node="cell2", since=start)
        assert again.payload.seq == 0
        assert again.values["bdSeq"] == nbirth.values["bdSeq"]
        for device in ("gantry", "head", "handler"):
            await central.wait_for("DBIRTH", node="cell2", device=device, since=start)
    finally:
        cell.kill()
    death = await central.wait_for("NDEATH", node="cell2")
    assert death.payload.seq is None
    assert death.values == {"bdSeq": nbirth.values["bdSeq"]}
