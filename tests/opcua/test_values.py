"""The status of a value and what its DataValue carries: never the last good number as Good."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest
from asyncua import ua

from gateway.errors import ConflictError, DeviceError, InvalidInputError, NotFoundError
from gateway.opcua.status import freshness, refusal_status
from gateway.opcua.values import Shown

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
