"""Local and remote control (gateway.service.control): who puts a controller in local, what
``check`` refuses, and which changes are published, on ``ControlStates`` itself and with the
key switch read on the simulated line by the running services."""

from __future__ import annotations

from typing import Any

import pytest

from gateway.errors import ConflictError
from gateway.service.config import GatewayConfig, parse_config
from gateway.service.control import ControlChange, ControlState, ControlStates
from gateway.service.events import EventKind, ServiceEvent, ServiceEvents
from gateway.service.operations.terms import Unit
from gateway.service.runtime.simulated import SIM_LOOP
from gateway.service.topology import Topology
from gateway.sim.control import Controls
from tests.support.fake_clock import FakeClock
from tests.support.sim_app import running_services


def switched(active: str = "on") -> GatewayConfig:
    """Bodies 1 and 2; body 1 has a key switch on general input bit 3."""
    controllers: list[dict[str, Any]] = [
        {"body": "1", "name": "gantry", "axes": [{"motor": 1, "name": "x"}],
         "local_input": {"bit": 3, "active": active}},
        {"body": "2", "name": "head", "axes": [{"motor": 1, "name": "z"}]},
    ]  # fmt: skip
    loop = {"name": SIM_LOOP, "port": "sim://line-worker", "controllers": controllers}
    return parse_config({"loops": [loop]}, "test")


def states(active: str = "on") -> tuple[ControlStates, list[ServiceEvent], list[ControlChange]]:
    events = ServiceEvents()
    seen: list[ServiceEvent] = []
    events.subscribe(seen.append)
    control = ControlStates(Topology(switched(active)), events, clock=FakeClock())
    changes: list[ControlChange] = []
    control.changes.subscribe(changes.append)
    return control, seen, changes


def test_a_key_switch_not_read_yet_counts_as_local() -> None:
    control, _, _ = states()
    gantry = control.topology.controller("gantry")
    view = control.view(gantry)
    assert view.state is ControlState.LOCAL
    assert [(s.kind, s.by) for s in view.sources] == [("key_switch", "input bit 3 not read yet")]
    assert view.key_switch is not None and view.key_switch.input_on is None
    with pytest.raises(ConflictError) as refused:
        control.check(gantry, "move sim.1.1")
    assert refused.value.field == "control" and "input bit 3 not read yet" in str(refused.value)
    control.check(control.topology.controller("head"), "move sim.2.1")  # no switch: remote


def test_the_switch_level_that_means_local_is_configured() -> None:
    control, _, _ = states(active="off")
    gantry = control.topology.controller("gantry")
    control.set_input(gantry, True)
    assert control.state(gantry) is ControlState.REMOTE
    control.set_input(gantry, False)
    assert control.state(gantry) is ControlState.LOCAL
    assert control.view(gantry).sources[0].by == "input bit 3 off"


def test_only_a_change_is_published_not_a_re_read() -> None:
    control, seen, changes = states()
    gantry = control.topology.controller("gantry")
    control.set_input(gantry, False)  # not read -> off: remote now
    control.set_input(gantry, False)  # read again, same level: nothing new
    assert [(c.previous, c.view.state, c.source) for c in changes] == [
        (ControlState.LOCAL, ControlState.REMOTE, "key_switch")
    ]
    (event,) = seen
    assert (event.kind, event.topic) == (EventKind.CONTROL, "controller:sim.1")
    assert (event.data["state"], event.data["previous"]) == ("remote", "local")
    assert event.data["cause"] == "key switch: input bit 3 off"
    assert event.data["axes"] == ["sim.1.1", "sim.1.2"]


def test_sources_add_up_and_each_lifts_only_itself() -> None:
    control, _, changes = states()
    gantry = control.topology.controller("gantry")
    control.set_input(gantry, False)
    control.set_controller(gantry, ControlState.LOCAL, "ann")
    control.set_loop(SIM_LOOP, ControlState.LOCAL, "bob")
    assert [s.kind for s in control.view(gantry).sources] == ["controller", "loop"]
    control.set_controller(gantry, ControlState.REMOTE, "ann")
    assert control.state(gantry) is ControlState.LOCAL  # the loop's setting still holds
    control.set_loop(SIM_LOOP, ControlState.REMOTE, "bob")
    assert control.state(gantry) is ControlState.REMOTE
    # remote -> local (ann), reasons change (bob), (ann lifted), local -> remote (bob) on sim.1;
    # and sim.2 followed the loop both ways
    assert [(c.controller.id, c.view.state.value, c.source) for c in changes[1:]] == [
        ("sim.1", "local", "controller"),
        ("sim.1", "local", "loop"),
        ("sim.2", "local", "loop"),
        ("sim.1", "local", "controller"),
        ("sim.1", "remote", "loop"),
        ("sim.2", "remote", "loop"),
    ]


def test_a_held_loop_refuses_naming_the_loop_and_its_reason_until_released() -> None:
    control, seen, _ = states()
    head = control.topology.controller("head")
    control.hold(SIM_LOOP, "changing the baud rate to 19200")
    with pytest.raises(ConflictError) as refused:
        control.check(head, "move sim.2.1")
    assert refused.value.field == "loop"
    assert "loop sim is held (changing the baud rate to 19200)" in str(refused.value)
    assert control.state(head) is ControlState.REMOTE and seen == []  # not a control state
    control.release(SIM_LOOP)
    control.check(head, "move sim.2.1")


async def test_the_key_switch_read_on_the_line_refuses_a_move_until_it_is_off() -> None:
    async with running_services(("1", "2"), config=switched()) as gw:
        gantry = gw.runtime.topology.controller("gantry")
        Controls(gw.sim).input("1", 3, on=True)
        await gw.until(lambda: gw.runtime.control.view(gantry).key_switch.input_on is True)  # type: ignore[union-attr]
        mark = gw.mark()
        with pytest.raises(ConflictError) as refused:
            await gw.services.axes.move("x", 100, relative=False, unit=Unit.PULSE, holder="a")
        assert refused.value.field == "control"
        assert "key switch: input bit 3 on" in str(refused.value)
        assert gw.acted("1", mark) == []
        Controls(gw.sim).input("1", 3, on=False)
        await gw.until(lambda: gw.runtime.control.state(gantry) is ControlState.REMOTE)
        await gw.services.axes.move("x", 100, relative=False, unit=Unit.PULSE, holder="a")
        assert gw.acted("1", mark)[-2:] == ["2100", "3"]
        causes = [e.data["cause"] for e in gw.events if e.kind is EventKind.CONTROL]
        assert causes[-2:] == ["key switch: input bit 3 on", "key switch: input bit 3 off"]
