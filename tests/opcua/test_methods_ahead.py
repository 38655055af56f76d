"""An OPC UA call that acts is written ahead (DESIGN invariant 14): when its audit entry
cannot be written the call is refused ``BadResourceUnavailable`` and nothing acts; a stop
still goes, its entry queued."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pytest
from asyncua import ua

from gateway.opcua.methods import Methods, StatusRefusal
from gateway.opcua.users import _CALLER, GatewayUser
from gateway.service.audit import AuditUnavailable
from gateway.service.roles import Role


class Axes:
    """Records what the service was asked to do."""

    def __init__(self) -> None:
        self.asked: list[str] = []

    async def move(self, axis: str, position: float, **_: Any) -> Any:
        self.asked.append(f"move {axis} {position}")
        return type("Op", (), {"id": 7})()

    async def stop(self, axis: str, mode: Any) -> Any:
        self.asked.append(f"stop {axis}")
        return type("Outcome", (), {"outcome": "done"})()


class FullDisk:
    """``AuditRecord.write_ahead`` on a disk that takes no write: a stop's entry is queued."""

    def __init__(self) -> None:
        self.tried: list[tuple[str, bool, bool]] = []

    async def __call__(
        self, entry: Mapping[str, Any], *, motion: bool, stop: bool = False
    ) -> int | None:
        self.tried.append((entry["path"], motion, stop))
        if stop:
            return None
        raise AuditUnavailable("audit: no space left on device")


@pytest.fixture
def operator() -> Any:
    user = GatewayUser(name="op")
    user.gateway_role = Role.OPERATOR
    reset = _CALLER.set(user)
    yield user
    _CALLER.reset(reset)


async def test_a_move_whose_entry_cannot_be_written_is_refused_and_never_asked(
    operator: GatewayUser,
) -> None:
    axes, ahead, outcomes = Axes(), FullDisk(), []
    methods = Methods(axes, stops=None, audit=outcomes.append, ahead=ahead)  # type: ignore[arg-type]
    with pytest.raises(StatusRefusal) as refused:
        await methods.move("x", 100, "pulse", relative=False)
    assert refused.value.status == ua.StatusCodes.BadResourceUnavailable
    assert "nothing was sent" in str(refused.value)
    assert axes.asked == []
    assert ahead.tried == [("axes/x/MoveAbsolute", True, False)]
    assert [o["status"] for o in outcomes] == ["BadResourceUnavailable"]


async def test_a_stop_goes_while_the_file_takes_no_write(operator: GatewayUser) -> None:
    axes, ahead, outcomes = Axes(), FullDisk(), []
    methods = Methods(axes, stops=None, audit=outcomes.append, ahead=ahead)  # type: ignore[arg-type]
    assert await methods.stop_axis("x", "decelerate") == "done"
    assert axes.asked == ["stop x"]
    assert ahead.tried == [("axes/x/Stop", False, True)]
    assert [o["status"] for o in outcomes] == ["Good"]
