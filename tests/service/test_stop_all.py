"""Stop-all (gateway.service.stops) called on the services of ``compose``: a stop is never
refused, ends the operation in progress, and reports every controller of a loop, each with
what went out on the line (the simulated controllers' own log)."""

from __future__ import annotations

from gateway.bus.requests import Outcome
from gateway.service.control import ControlState
from gateway.service.operations.terms import Direction, JogSpeed, StopMode
from gateway.service.operations.types import OperationState
from gateway.sim.control import Controls
from tests.support.sim_app import running_services

WAIT = 20.0


async def test_a_controller_stop_passes_local_control_and_a_lease_and_ends_the_jog() -> None:
    async with running_services(("1",)) as gw:
        jog = await gw.services.axes.jog("y", Direction.CW, JogSpeed.LOW, holder="alice")
        await gw.until(lambda: gw.cached("1").moving is True)
        ref = gw.runtime.topology.controller("gantry")
        gw.runtime.control.set_controller(ref, ControlState.LOCAL, "ops-admin")
        gw.leases.acquire("sim.1", "alice", 60.0)
        mark = gw.mark()
        stop = await gw.services.stops.controller("gantry", StopMode.DECELERATE)
        assert (stop.controller, stop.axes) == ("sim.1", ["sim.1.1", "sim.1.2"])
        assert (stop.command, stop.outcome, stop.error) == ("SS", Outcome.DONE, None)
        assert stop.operation == jog.id
        assert [f.rstrip("\r")[2:] for f in stop.frames] == ["SS"]
        assert gw.acted("1", mark) == ["SS"]  # one frame: only the selected motor moves (§2)
        ended = await gw.operations.wait(jog.id, WAIT)
        assert ended.state is OperationState.DONE  # a jog ends by a stop (docs/api-notes.md)
        await gw.until(lambda: gw.cached("1").moving is False)


async def test_a_loop_stop_reports_the_controller_that_does_not_answer() -> None:
    async with running_services(("1", "2", "3")) as gw:
        everyone = await gw.services.stops.loop("sim", StopMode.IMMEDIATE)
        assert everyone.outcome is Outcome.DONE
        Controls(gw.sim).power("2", on=False)
        await gw.until(lambda: gw.cached("2").online is False)
        mark = gw.mark()
        result = await gw.services.stops.loop("sim", StopMode.IMMEDIATE)
        assert [s.controller for s in result.stops] == ["sim.1", "sim.2", "sim.3"]
        first, silent, third = result.stops
        assert first.outcome is third.outcome is Outcome.DONE
        # no reply: the stop may have been heard, or not (the read-back cannot tell either)
        assert silent.outcome is Outcome.UNKNOWN, silent
        assert silent.error == "the reply to the stop was lost and the read-back could not decide"
        assert result.outcome is Outcome.UNKNOWN
        assert gw.acted("1", mark) == gw.acted("3", mark) == ["S"]
        # its stop went out all the same (the line carries it; the controller is off)
        assert gw.acted("2", mark) and set(gw.acted("2", mark)) == {"S"}
