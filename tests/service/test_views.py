"""What the services give a client to read (gateway.service.views through AxisService and
ControllerService), over the simulated line: positions in pulses and user units, latched
errors until acknowledged, the controller, its loop."""

from __future__ import annotations

from gateway.bus.state_types import ErrorKind
from gateway.service.control import ControlState
from gateway.service.operations.terms import Unit
from gateway.service.operations.types import OperationState
from gateway.sim.control import Controls
from tests.support.sim_app import running_services

WAIT = 20.0


async def test_an_axis_view_gives_pulses_and_user_units_and_reads_fresh_on_demand() -> None:
    async with running_services(("1",)) as gw:
        op = await gw.services.axes.move("x", 123.45, relative=False, unit=Unit.USER, holder="a")
        assert (await gw.operations.wait(op.id, WAIT)).state is OperationState.DONE
        view = await gw.services.axes.fresh("x")
        assert gw.position("1", 1) == 12_345
        assert (view.id, view.name, view.controller, view.motor) == ("sim.1.1", "x", "sim.1", 1)
        assert (view.position, view.position_user, view.unit) == (12_345, 123.45, "mm")
        assert view.units == {
            "position": "pulse", "counter": "pulse",
            "position_user": "mm", "soft_min": "mm", "soft_max": "mm",
        }  # fmt: skip
        assert (view.soft_min, view.soft_max) == (-40.0, 940.0)
        assert (view.moving, view.homed, view.origin) == (False, False, "unknown")
        assert view.control.state is ControlState.REMOTE
        assert [v.id for v in gw.services.axes.views()] == ["sim.1.1", "sim.1.2"]
        assert gw.services.axes.view("sim.1.1") == gw.services.axes.view("x")


async def test_an_emergency_stop_stays_shown_until_acknowledged() -> None:
    async with running_services(("1",)) as gw:
        controls = Controls(gw.sim)
        controls.ems("1", pressed=True)
        await gw.until(lambda: gw.services.axes.view("x").errors.emergency)
        controls.ems("1", pressed=False)
        released = gw.runtime.state.seq
        await gw.until(lambda: gw.runtime.state.seq > released + 2)  # polled again since
        assert gw.services.axes.view("x").errors.emergency  # latched: the device forgot it
        latched = gw.services.controllers.view("gantry").latched
        assert [(e.kind, e.axes) for e in latched] == [("emergency_stop", [1, 2])]
        view = gw.services.axes.acknowledge("x", [ErrorKind.EMERGENCY])
        assert not view.errors.emergency
        assert gw.services.axes.view("y").errors.emergency  # each axis acknowledges its own
        latched = gw.services.controllers.view("gantry").latched
        assert [(e.kind, e.axes) for e in latched] == [("emergency_stop", [2])]
        gw.services.axes.acknowledge("y", None)
        assert gw.services.controllers.view("gantry").latched == []


async def test_controller_and_loop_views() -> None:
    async with running_services(("1", "2")) as gw:
        Controls(gw.sim).power("2", on=False)
        await gw.until(lambda: gw.cached("2").online is False)
        gantry = gw.services.controllers.view("gantry")
        assert (gantry.id, gantry.body, gantry.online, gantry.axes) == (
            "sim.1", "1", True, ["sim.1.1", "sim.1.2"]
        )  # fmt: skip
        assert gantry.mode is not None and gantry.moving is False
        assert gw.services.controllers.view("sim.2").online is False
        loop = gw.services.controllers.loop("sim")
        assert (loop.name, loop.up, loop.cause, loop.controllers) == (
            "sim", True, None, ["sim.1", "sim.2"]
        )  # fmt: skip
        assert loop.baud == gw.runtime.config.loops[0].baud
        assert loop.counters is not None and loop.counters.transactions > 0
