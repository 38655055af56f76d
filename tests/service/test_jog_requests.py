"""A jog asked again while it runs (gateway.service.axes.service.AxisService.jog), called on
the services of ``compose`` over the simulated line: the same jog is the same operation; only
its speed may change (§10 H, L), and that is a setting from the network like any other."""

from __future__ import annotations

from typing import Any

import pytest

from gateway.errors import ConflictError
from gateway.service.config import GatewayConfig, parse_config
from gateway.service.control import ControlState
from gateway.service.operations.asked import JogAsked
from gateway.service.operations.terms import Direction, JogSpeed, StopMode
from gateway.service.operations.types import OperationState
from gateway.service.runtime.simulated import SIM_LOOP
from tests.support.sim_app import running_services

WAIT = 20.0


def free_y() -> GatewayConfig:
    """Body 1: x with soft limits (-4,000 .. 94,000 pulses), y without."""
    axes: list[dict[str, Any]] = [
        {"motor": 1, "name": "x", "soft_min": -4000, "soft_max": 94000},
        {"motor": 2, "name": "y"},
    ]
    controllers = [{"body": "1", "name": "gantry", "axes": axes}]
    loop = {"name": SIM_LOOP, "port": "sim://line-worker", "controllers": controllers}
    return parse_config({"loops": [loop]}, "test")


async def test_a_running_jog_changes_speed_with_h_and_is_refused_that_in_local() -> None:
    async with running_services(("1",), config=free_y()) as gw:
        axes = gw.services.axes
        mark = gw.mark()
        jog = await axes.jog("y", Direction.CW, JogSpeed.LOW, holder="alice")
        await gw.until(lambda: gw.operations.get(jog.id).state is OperationState.MOVING)
        assert gw.acted("1", mark)[-1:] == ["7"]
        again = await axes.jog("y", Direction.CW, JogSpeed.LOW, holder="alice")
        # the same operation: no new 7, its speed set again (§10 L, while turning)
        assert again is jog and gw.acted("1", mark)[-2:] == ["7", "L"]
        gw.runtime.control.set_controller(
            gw.runtime.topology.controller("gantry"), ControlState.LOCAL, "ops-admin"
        )
        mark = gw.mark()
        with pytest.raises(ConflictError) as refused:
            await axes.jog("y", Direction.CW, JogSpeed.HIGH, holder="alice")
        assert refused.value.field == "control"
        assert "change the jog speed of sim.1.2" in str(refused.value)
        assert gw.acted("1", mark) == []
        assert isinstance(jog.asked, JogAsked) and jog.asked.speed is JogSpeed.LOW
        gw.runtime.control.set_controller(
            gw.runtime.topology.controller("gantry"), ControlState.REMOTE, "ops-admin"
        )
        faster = await axes.jog("y", Direction.CW, JogSpeed.HIGH, holder="alice")
        assert faster is jog and gw.acted("1", mark) == ["H"]  # §10 H: while turning
        assert isinstance(jog.asked, JogAsked) and jog.asked.speed is JogSpeed.HIGH
        await axes.stop("y", StopMode.DECELERATE)
        assert (await gw.operations.wait(jog.id, WAIT)).state is OperationState.DONE


async def test_a_jog_to_a_soft_limit_keeps_its_speed_and_another_client_cannot_take_it() -> None:
    async with running_services(("1",), config=free_y()) as gw:
        axes = gw.services.axes
        jog = await axes.jog("x", Direction.CW, JogSpeed.LOW, holder="alice")
        assert jog.target == 94_000  # a move to the soft limit at the jog speed
        gw.leases.acquire("sim.1.1", "alice", 60.0)
        mark = gw.mark()
        with pytest.raises(ConflictError) as refused:
            await axes.jog("x", Direction.CW, JogSpeed.LOW, holder="bob")
        assert (refused.value.field, refused.value.holder) == ("lease", "alice")
        assert await axes.jog("x", Direction.CW, JogSpeed.LOW, holder="alice") is jog
        with pytest.raises(ConflictError) as refused:
            await axes.jog("x", Direction.CW, JogSpeed.HIGH, holder="alice")
        assert refused.value.field == "speed" and "§10 H, L" in str(refused.value)
        assert gw.acted("1", mark) == []
        await axes.stop("x", StopMode.IMMEDIATE)
        assert (await gw.operations.wait(jog.id, WAIT)).state is OperationState.DONE
