"""Ids, names, units and soft limits of the configured axes."""

from __future__ import annotations

import pytest

from gateway.errors import InvalidInputError, NotFoundError
from gateway.service.runtime.simulated import simulated_config
from gateway.service.topology import Topology


@pytest.fixture
def topology() -> Topology:
    return Topology(simulated_config())


def test_ids_and_names_find_the_same_axis(topology: Topology) -> None:
    assert topology.axis("theta") == topology.axis("sim.2.2")
    assert topology.axis("sim.2.2").controller_id == "sim.2"
    assert topology.controller("gantry").id == "sim.1"
    assert [a.id for a in topology.controller("sim.1").axes] == ["sim.1.1", "sim.1.2"]
    assert [a.name for a in topology.axes()] == ["x", "y", "z", "theta", "gripper", "conveyor"]


def test_unknown_ids_are_refused_with_what_exists(topology: Topology) -> None:
    with pytest.raises(NotFoundError, match=r"no axis 'sim\.4\.1'; known: sim\.1\.1") as caught:
        topology.axis("sim.4.1")
    assert caught.value.kind == "axis"
    with pytest.raises(NotFoundError, match="no controller 'x'"):
        topology.controller("x")  # an axis name is not a controller
    with pytest.raises(NotFoundError, match="no loop 'main'"):
        topology.loop("main")


def test_user_units_convert_to_whole_pulses(topology: Topology) -> None:
    x = topology.axis("x")  # 0.01 mm a pulse
    assert x.to_pulses(12.34, "position") == 1234
    assert x.to_user(1234) == 12.34
    with pytest.raises(InvalidInputError) as caught:
        x.to_pulses(12.345, "position")
    assert caught.value.field == "position"
    assert "whole number of pulses of 0.01 mm" in caught.value.rule


def test_soft_limits_and_the_position_counter_refuse_targets(topology: Topology) -> None:
    x = topology.axis("x")  # soft limits -40 .. 940 mm
    x.check_target(94_000, "position")
    with pytest.raises(InvalidInputError) as caught:
        x.check_target(94_001, "position")
    assert caught.value.field == "position"
    assert caught.value.rule == "soft limits [-40, 940] mm (configuration)"
    gripper = topology.axis("gripper")
    with pytest.raises(InvalidInputError, match="outside the position counter"):
        gripper.check_target(16_777_216, "position")  # §7-4: 24 bits (the format narrows it)
