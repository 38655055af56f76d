"""What the soft-limit guard (gateway.service.axes.soft_limits) turns a catalog motion command
into before it is sent, called on the services of ``compose`` over the simulated line.

Body 1 here: x with soft limits -40 .. 940 mm (0.01 mm a pulse: -4,000 .. 94,000 pulses),
y with none. ``guard`` only reads (``6{mt}``, ``2D``, ``A{pn}D``): what it returns is what
the runner sends, and a refusal leaves the controller having heard nothing that changes it.
"""

from __future__ import annotations

import pytest

from gateway.errors import ConflictError, InvalidInputError
from gateway.protocol.command_text import parse
from gateway.service.axes.origin_guard import HOME_FIRST_RULE
from gateway.service.axes.soft_limits import UNKNOWN_TARGET_RULE, Guarded, SoftLimits
from gateway.service.config import GatewayConfig, parse_config
from gateway.service.operations.terms import HomeMethod, Unit
from gateway.service.operations.types import OperationState
from gateway.service.runtime.simulated import SIM_LOOP
from gateway.sim.control import Controls
from tests.support.sim_app import SimGateway, running_services

WAIT = 20.0


def limited_x() -> GatewayConfig:
    axes = [
        {"motor": 1, "name": "x", "unit": "mm", "units_per_pulse": 0.01,
         "soft_min": -40.0, "soft_max": 940.0},
        {"motor": 2, "name": "y"},
    ]  # fmt: skip
    controllers = [{"body": "1", "name": "gantry", "axes": axes}]
    loop = {"name": SIM_LOOP, "port": "sim://line-worker", "controllers": controllers}
    return parse_config({"loops": [loop]}, "test")


async def guard(gw: SimGateway, texts: list[str], motor: int | None) -> Guarded:
    ref = gw.runtime.topology.controller("gantry")
    return await SoftLimits(gw.runtime).guard(ref, [parse(t) for t in texts], motor, "text")


def wires(guarded: Guarded) -> list[str]:
    return [c.wire() for c in guarded.commands]


async def send(gw: SimGateway, text: str) -> None:
    await gw.services.controllers.raw(SIM_LOOP, "1", text, motor=None, holder="alice")


async def test_3_is_sent_with_the_position_data_it_was_checked_against() -> None:
    async with running_services(("1",), config=limited_x()) as gw:
        await send(gw, "290000")  # 900 mm: inside
        mark = gw.mark()
        guarded = await guard(gw, ["3"], motor=1)
        assert wires(guarded) == ["290000", "3"] and guarded.motor == 1
        assert gw.acted("1", mark) == []  # checked by reading: nothing moved, nothing written
        await send(gw, "295000")  # 950 mm: past the soft maximum
        mark = gw.mark()
        with pytest.raises(InvalidInputError) as refused:
            await guard(gw, ["3"], motor=1)
        assert refused.value.field == "text"
        assert "would move axis sim.1.1 to 95000 pulses" in str(refused.value)
        assert "940" in refused.value.rule
        with pytest.raises(InvalidInputError):  # the runner refuses it the same way
            await send(gw, "3")
        assert gw.acted("1", mark) == []
        assert gw.position("1", 1) == 0


async def test_4_and_5_are_checked_from_the_position_read_now() -> None:
    async with running_services(("1",), config=limited_x()) as gw:
        await send(gw, "25000")
        assert gw.position("1", 1) == 0
        assert wires(await guard(gw, ["4"], motor=1)) == ["25000", "4"]  # CW: to 5,000
        with pytest.raises(InvalidInputError) as refused:  # CCW below 0, unsigned (EP0)
            await guard(gw, ["5"], motor=1)
        assert "to -5000 pulses" in str(refused.value) and "EP0" in refused.value.rule
        await send(gw, "EP1")  # signed: below 0 is a position, and the soft minimum decides
        await send(gw, "23000")
        # to -3,000: inside; the data is written again in the signed form
        assert wires(await guard(gw, ["5"], motor=1)) == ["2+3000", "5"]
        await send(gw, "25000")
        with pytest.raises(InvalidInputError) as refused:  # to -5,000: below -40 mm
            await guard(gw, ["5"], motor=1)
        assert "to -5000 pulses" in str(refused.value) and "-40" in refused.value.rule


async def test_a_table_entry_move_is_sent_with_the_entry_it_was_checked_against() -> None:
    async with running_services(("1",), config=limited_x()) as gw:
        await send(gw, "A00150000")
        assert wires(await guard(gw, ["B001"], motor=1)) == ["A00150000", "B001"]
        await send(gw, "A00199000")
        with pytest.raises(InvalidInputError) as refused:
            await guard(gw, ["B001"], motor=1)
        assert "to 99000 pulses" in str(refused.value)


async def test_a_jog_command_has_no_known_target_and_is_refused_naming_the_rule() -> None:
    async with running_services(("1",), config=limited_x()) as gw:
        mark = gw.mark()
        with pytest.raises(InvalidInputError) as refused:
            await guard(gw, ["7"], motor=1)
        assert refused.value.field == "text" and refused.value.rule == UNKNOWN_TARGET_RULE
        with pytest.raises(InvalidInputError) as refused:  # the motor in the command counts
            await guard(gw, ["81"], motor=2)
        assert refused.value.rule == UNKNOWN_TARGET_RULE
        assert gw.acted("1", mark) == []


async def test_moves_to_the_origin_pass_and_an_axis_without_limits_is_not_touched() -> None:
    async with running_services(("1",), config=limited_x()) as gw:
        assert wires(await guard(gw, ["1"], motor=1)) == ["1"]  # to 0: inside
        guarded = await guard(gw, ["7"], motor=2)  # y has no soft limits
        assert wires(guarded) == ["7"] and guarded.motor == 2


async def test_a_relative_table_move_is_checked_from_the_position_by_the_entrys_size() -> None:
    async with running_services(("1",), config=limited_x()) as gw:
        await send(gw, "EP1")
        await send(gw, "A0013000")
        # B001- moves by |A001| CCW (§10 B+(-)): to -3,000, inside; the entry is written again
        assert wires(await guard(gw, ["B001-"], motor=1)) == ["A001+3000", "B001-"]
        await send(gw, "A0015000")
        with pytest.raises(InvalidInputError) as refused:  # to -5,000: below -40 mm
            await guard(gw, ["B001-"], motor=1)
        assert "to -5000 pulses" in str(refused.value) and "-40" in refused.value.rule


async def test_after_a_reset_a_motion_on_a_limited_axis_waits_for_a_home() -> None:
    async with running_services(("1",), config=limited_x()) as gw:
        home = await gw.services.axes.home("x", HomeMethod.SEARCH_1, holder="alice")
        assert (await gw.operations.wait(home.id, WAIT)).state is OperationState.DONE
        move = await gw.services.axes.move(
            "x", 1000, relative=False, unit=Unit.PULSE, holder="alice"
        )
        assert (await gw.operations.wait(move.id, WAIT)).state is OperationState.DONE
        Controls(gw.sim).power_cycle("1")  # RAM lost, counters at 0 where the axes stand (§16)
        mark = gw.mark()
        with pytest.raises(ConflictError) as refused:  # the reading made now shows the reset
            await guard(gw, ["3"], motor=1)
        assert refused.value.field == "text" and refused.value.rule == HOME_FIRST_RULE
        assert "controller sim.1 was reset" in str(refused.value)
        assert gw.acted("1", mark) == []
