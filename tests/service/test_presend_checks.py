"""Every check made before something is sent on a client's behalf (gateway.service.presend),
called on the services of ``compose`` with the simulator behind the real serial path.

A refusal names its field and rule and leaves the line silent: the simulated controller hears
nothing that changes anything (``acted``: its log minus the poller's queries).
"""

from __future__ import annotations

import pytest

from gateway.bus.requests import LoopDown
from gateway.bus.scheduler import LinkState
from gateway.errors import ConflictError, DeviceError, InvalidInputError
from gateway.protocol.command_text import parse
from gateway.service.control import ControlState
from gateway.service.events import EventKind
from gateway.service.operations.terms import Direction, HomeMethod, JogSpeed, StopMode, Unit
from gateway.service.operations.types import OperationState
from gateway.sim.control import Controls
from tests.support.sim_app import SimGateway, running_services

WAIT = 20.0


async def move(gw: SimGateway, axis: str, pulses: int, holder: str = "alice") -> None:
    await gw.services.axes.move(axis, pulses, relative=False, unit=Unit.PULSE, holder=holder)


async def test_an_axis_leased_by_another_refuses_a_move_and_nothing_is_sent() -> None:
    async with running_services(("1",)) as gw:
        gw.leases.acquire("sim.1.1", "alice", 60.0)
        mark = gw.mark()
        with pytest.raises(ConflictError) as refused:
            await move(gw, "x", 100, holder="bob")
        assert refused.value.field == "lease" and refused.value.holder == "alice"
        assert "sim.1.1 is leased by 'alice'" in str(refused.value)
        assert gw.acted("1", mark) == []
        # the holder's own move goes out
        op = await gw.services.axes.move("x", 100, relative=False, unit=Unit.PULSE, holder="alice")
        assert op.state is not OperationState.FAILED
        assert gw.acted("1", mark)[-2:] == ["2100", "3"]


async def test_a_controller_lease_guards_both_axes_but_never_a_stop() -> None:
    async with running_services(("1",)) as gw:
        gw.leases.acquire("sim.1", "alice", 60.0)
        mark = gw.mark()
        for axis in ("x", "y"):
            with pytest.raises(ConflictError) as refused:
                await move(gw, axis, 100, holder="bob")
            assert (refused.value.field, refused.value.holder) == ("lease", "alice")
        with pytest.raises(ConflictError):  # a catalog setting needs the controller free too
            await gw.services.controllers.raw("sim", "1", "OH100", motor=1, holder="bob")
        assert gw.acted("1", mark) == []
        stop = await gw.services.axes.stop("y", StopMode.IMMEDIATE)
        assert stop.outcome.value == "done"
        assert gw.acted("1", mark) == ["S"]


async def test_local_control_refuses_motion_and_settings_but_not_queries_or_stops() -> None:
    async with running_services(("1",)) as gw:
        ref = gw.runtime.topology.controller("gantry")
        gw.runtime.control.set_controller(ref, ControlState.LOCAL, "ops-admin")
        mark = gw.mark()
        with pytest.raises(ConflictError) as refused:
            await move(gw, "x", 100)
        assert refused.value.field == "control"
        assert "sim.1 is in local control" in str(refused.value)
        assert "ops-admin" in str(refused.value)
        with pytest.raises(ConflictError) as refused:
            await gw.services.controllers.raw("sim", "1", "2100", motor=None, holder="alice")
        assert refused.value.field == "control" and "'2100'" in str(refused.value)
        answer = await gw.services.controllers.raw("sim", "1", "61", motor=None, holder="alice")
        assert answer.outcome == "done"
        assert gw.acted("1", mark) == []
        stop = await gw.services.axes.stop("x", StopMode.DECELERATE)
        assert stop.outcome.value == "done" and gw.acted("1", mark) == ["SS"]
        # remote again: the same move goes out
        gw.runtime.control.set_controller(ref, ControlState.REMOTE, "ops-admin")
        await move(gw, "x", 100)
        assert gw.acted("1", mark)[-2:] == ["2100", "3"]


async def test_a_loop_set_local_refuses_every_controller_of_it() -> None:
    async with running_services(("1", "2")) as gw:
        gw.runtime.control.set_loop("sim", ControlState.LOCAL, "ops-admin")
        mark = gw.mark()
        for axis in ("x", "theta"):
            with pytest.raises(ConflictError) as refused:
                await move(gw, axis, 100)
            assert refused.value.field == "control" and "on its loop" in str(refused.value)
        view = gw.services.axes.view("theta")
        assert view.control.state is ControlState.LOCAL
        assert [(s.kind, s.by) for s in view.control.sources] == [("loop", "ops-admin")]
        assert gw.acted("1", mark) == gw.acted("2", mark) == []


async def test_a_moving_controller_refuses_its_other_axis_and_settings_not_usable_then() -> None:
    async with running_services(("1",)) as gw:
        jog = await gw.services.axes.jog("x", Direction.CW, JogSpeed.LOW, holder="alice")
        mark = gw.mark()
        with pytest.raises(ConflictError) as refused:
            await move(gw, "y", 100)
        assert refused.value.field == "axis"
        assert "controller sim.1 is moving (sim.1.1)" in str(refused.value)
        assert "§2" in str(refused.value)
        await gw.until(lambda: gw.cached("1").moving is True)
        with pytest.raises(ConflictError) as refused:  # §10 F: not while a motor moves
            await gw.services.controllers.raw("sim", "1", "F2", motor=None, holder="alice")
        assert refused.value.field == "command" and "not usable while moving" in str(refused.value)
        assert gw.acted("1", mark) == []
        await gw.services.axes.stop("x", StopMode.IMMEDIATE)
        ended = await gw.operations.wait(jog.id, WAIT)
        assert ended.state in (OperationState.FAILED, OperationState.DONE)
        assert gw.acted("1", mark) == ["S"]


async def test_an_offline_controller_refuses_an_axis_action_and_nothing_is_sent() -> None:
    async with running_services(("1", "2")) as gw:
        Controls(gw.sim).power("2", on=False)
        await gw.until(lambda: gw.cached("2").online is False)
        mark = gw.mark()
        with pytest.raises(DeviceError) as refused:
            await move(gw, "z", 100)
        assert refused.value.outcome == "not_done" and refused.value.timeout
        assert "controller sim.2 does not answer" in str(refused.value)
        assert gw.acted("2", mark) == []


async def test_forms_never_sent_for_a_client_are_refused_naming_the_field() -> None:
    async with running_services(("1",)) as gw:
        mark = gw.mark()
        with pytest.raises(InvalidInputError) as refused:
            await gw.services.controllers.raw("sim", "1", "I", motor=None, holder="alice")
        assert refused.value.field == "text" and "§10 I" in refused.value.rule
        with pytest.raises(InvalidInputError) as refused:
            await gw.services.controllers.command("gantry", parse("ES2"), holder="alice")
        assert refused.value.field == "command" and "§10 ES" in refused.value.rule
        assert gw.acted("1", mark) == []


async def test_a_form_outside_the_controllers_mode_is_refused_with_the_modes_it_needs() -> None:
    async with running_services(("1",)) as gw:
        await gw.services.controllers.raw("sim", "1", "E1", motor=None, holder="alice")
        assert gw.cached("1").mode == 1  # read back after E: the checks see the new mode
        mark = gw.mark()
        with pytest.raises(InvalidInputError) as refused:
            await gw.services.controllers.raw("sim", "1", "EP1", motor=None, holder="alice")
        assert refused.value.field == "command"
        assert "mode 1" in str(refused.value) and "modes 0, 2 only" in refused.value.rule
        assert gw.acted("1", mark) == []


async def test_a_dead_loop_refuses_after_the_lease_and_before_anything_is_sent() -> None:
    async with running_services(("1",)) as gw:
        gw.leases.acquire("sim.1.1", "alice", 60.0)
        scheduler = gw.runtime.scheduler("sim")
        gw.sim.act(lambda now: gw.sim.set_cut(True, now))
        await gw.until(lambda: scheduler.state is not LinkState.UP)
        mark, seen = gw.mark(), len(gw.events)
        with pytest.raises(ConflictError) as leased:  # the lease is checked first
            await move(gw, "x", 100, holder="bob")
        assert leased.value.holder == "alice"
        with pytest.raises(LoopDown) as down:  # the line before the controller's state
            await gw.services.axes.home("x", HomeMethod.SEARCH_1, holder="alice")
        assert (down.value.loop, down.value.in_flight) == ("sim", False)
        assert "loop 'sim' is down" in str(down.value)
        # refused before an operation exists: none queued, none failed
        assert [e for e in gw.events[seen:] if e.kind is EventKind.OPERATION] == []
        gw.sim.act(lambda now: gw.sim.set_cut(False, now))
        assert gw.acted("1", mark) == []
