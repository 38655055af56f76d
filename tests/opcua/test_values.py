"""The status of a value and what its DataValue carries: never the last good number as Good."""

from __future__ import annotations

from datetime import UTC, datetime
from types import SimpleNamespace
from typing import Any

import pytest
from asyncua import ua

from gateway.bus.state import StateCache
from gateway.bus.state_types import Origin
from gateway.errors import ConflictError, DeviceError, InvalidInputError, NotFoundError
from gateway.opcua.status_codes import freshness, refusal_status
from gateway.opcua.values import (
    AXIS_VARIABLES,
    Shown,
    Target,
    axis_values,
    controller_values,
    loop_values,
)
from gateway.protocol.framing import Series
from gateway.service.topology import AxisRef, ControllerRef
from gateway.service.views import wall_time

S = ua.StatusCodes


@pytest.mark.parametrize(
    ("line_up", "online", "known", "stale", "status"),
    [
        (True, True, True, False, S.Good),
        (True, True, True, True, S.UncertainLastUsableValue),
        (True, None, False, True, S.BadWaitingForInitialData),
        (True, False, True, True, S.BadNoCommunication),
        (False, True, True, False, S.BadNoCommunication),
        (False, None, False, True, S.BadNoCommunication),
    ],
)
def test_freshness(line_up: bool, online: bool | None, known: bool, stale: bool,
                   status: int) -> None:  # fmt: skip
    assert freshness(line_up=line_up, online=online, known=known, stale=stale) == status


def test_a_stale_value_is_uncertain_with_its_reading_time() -> None:
    when = 1_800_000_000.25
    value = Shown(12.5, S.UncertainLastUsableValue, when).data_value(ua.VariantType.Double)
    assert value.Value.Value == 12.5
    assert value.StatusCode.value == S.UncertainLastUsableValue
    assert value.SourceTimestamp == datetime.fromtimestamp(when, UTC)


def test_a_bad_value_carries_no_number() -> None:
    value = Shown(12.5, S.BadNoCommunication, 1.0).data_value(ua.VariantType.Double)
    assert value.Value.Value is None
    assert value.StatusCode.value == S.BadNoCommunication


def test_refusals_map_to_the_status_codes_of_the_face() -> None:
    assert refusal_status(InvalidInputError("beyond", field="x")) == S.BadOutOfRange
    assert refusal_status(ConflictError("moving")) == S.BadInvalidState
    assert refusal_status(DeviceError("silent", outcome="not_done")) == S.BadNoCommunication
    assert refusal_status(NotFoundError("axis", "x")) == S.BadNotFound


# ---------------------------------------------------------------- values of the state cache

NOW = 1000.0
AXIS = AxisRef("main", "1", 1, "z", "mm", 0.01, -10.0, 100.0)


def _gateway(**axis: Any) -> Any:
    """A runtime as far as the values see it: a state cache with loop main, controller 1
    online and its axis 1 read at ``NOW`` (``axis``: its fields)."""
    cache = StateCache()
    cache.set_link("main", True, NOW)
    cache.set_online("main", "1", True, NOW)
    cache.write_axis(NOW, "main", "1", 1, **{"position": 1234, "stale": False,
                                             "updated": NOW, **axis})  # fmt: skip
    return SimpleNamespace(state=cache)


def test_an_axis_read_fresh_is_good_with_its_reading_time() -> None:
    shown = axis_values(_gateway(moving=False), AXIS, None)
    assert shown["ActualPosition"] == Shown(12.34, S.Good, wall_time(NOW))
    assert shown["ActualPositionPulses"] == Shown(1234, S.Good, wall_time(NOW))
    assert shown["Moving"] == Shown(False, S.Good, wall_time(NOW))


def test_a_flag_not_known_is_waiting_not_good_with_no_value() -> None:
    # a position read but not (yet) which motor moves: Moving is not known
    shown = axis_values(_gateway(moving=None), AXIS, None)
    assert shown["Moving"].status == S.BadWaitingForInitialData
    written = shown["Moving"].data_value(ua.VariantType.Boolean)
    assert written.StatusCode.value == S.BadWaitingForInitialData and written.Value.Value is None


def test_an_unknown_value_is_never_written_good() -> None:
    # asyncua refuses an empty Good value on a typed variable and keeps the previous one
    written = Shown(None, S.Good, 1.0).data_value(ua.VariantType.Boolean)
    assert written.StatusCode.value == S.BadWaitingForInitialData


def test_homed_is_shown_from_the_origin() -> None:
    assert "Homed" in AXIS_VARIABLES
    assert axis_values(_gateway(), AXIS, None)["Homed"] == Shown(False, S.Good, wall_time(NOW))
    homed = axis_values(_gateway(origin=Origin.HOMED), AXIS, None)["Homed"]
    assert homed == Shown(True, S.Good, wall_time(NOW))


def test_after_a_reset_the_user_position_is_not_trusted_the_pulses_are() -> None:
    shown = axis_values(_gateway(origin=Origin.LOST), AXIS, None)
    assert shown["ActualPosition"].status == S.BadWaitingForInitialData
    assert shown["ActualPosition"].data_value(ua.VariantType.Double).Value.Value is None
    assert shown["ActualPositionPulses"] == Shown(1234, S.Good, wall_time(NOW))
    assert shown["Homed"] == Shown(False, S.Good, wall_time(NOW))


def test_a_loop_s_values_carry_the_time_of_its_latest_change() -> None:
    shown = loop_values(_gateway(), "main", NOW + 5)
    assert shown["LineUp"] == Shown(True, S.Good, wall_time(NOW + 5))


def test_the_target_carries_the_time_it_was_set_not_the_axis_reading_s() -> None:
    set_at = wall_time(NOW + 7)
    assert set_at is not None
    shown = axis_values(_gateway(), AXIS, Target(2000, set_at))
    assert shown["TargetPosition"] == Shown(20.0, S.Good, set_at)
    assert axis_values(_gateway(), AXIS, None)["TargetPosition"].status == (
        S.BadWaitingForInitialData
    )


def test_a_controller_on_a_line_down_is_not_online_since_the_line_went_down() -> None:
    gateway = _gateway()
    gateway.state.set_link("main", False, NOW + 3, cause="cut")
    gateway.control = SimpleNamespace(view=lambda ref: SimpleNamespace(state=None))
    ref = ControllerRef("main", "1", None, Series.DOLLAR, (AXIS, AXIS))
    shown = controller_values(gateway, ref, NOW + 3)
    assert shown["Online"] == Shown(False, S.Good, wall_time(NOW + 3))
    assert shown["Mode"].status == S.BadNoCommunication
