"""The methods: per axis MoveAbsolute, MoveRelative, Home, Stop, AcknowledgeErrors; per
controller and per loop Stop. MDIS-style: a motion method returns once the motion is
accepted, with the operation's id; the client follows ``Moving`` or the operation.

Each call goes to the same service methods as the REST routes (the lease, soft limits, local
control and every other check are theirs), as the session's user (its token's name holds
leases), and is one entry of the audit record with ``method`` ``OPCUA`` and the method's
path as ``path``, refusals too. A call that acts has its intent written ahead of its first
frame, as a REST request's is (DESIGN invariant 14): when that entry cannot be written the
call is refused ``BadResourceUnavailable`` and nothing acts, stops excepted (their entry is
queued). A refusal answers with a status code (``status``).
"""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable, Mapping
from typing import Any

from asyncua import ua

from gateway.errors import GatewayError
from gateway.opcua.call_lanes import stopped_since_queued
from gateway.opcua.status_codes import refusal_status
from gateway.opcua.users import GatewayUser, caller
from gateway.service.audit import WriteAhead
from gateway.service.axes import AxisService
from gateway.service.operations.terms import HomeMethod, StopMode, Unit
from gateway.service.roles import Role
from gateway.service.stops import StopAll

__all__ = ["AUDIT_METHOD", "Methods", "StatusRefusal"]

AUDIT_METHOD = "OPCUA"

Audit = Callable[[Mapping[str, Any]], object]


class StatusRefusal(Exception):
    """A call refused before the service was asked: its status code and why."""

    def __init__(self, status: int, why: str) -> None:
        super().__init__(why)
        self.status = status


def _choice(kind: type[Any], value: Any, argument: str, default: Any) -> Any:
    if value in (None, ""):
        return default
    try:
        return kind(value)
    except ValueError:
        choices = ", ".join(str(m.value) for m in kind)
        raise StatusRefusal(
            ua.StatusCodes.BadInvalidArgument, f"{argument}: {value!r} is not one of {choices}"
        ) from None


class Methods:
    """What the methods do: service calls, role checks and the audit record."""

    def __init__(
        self, axes: AxisService, stops: StopAll, audit: Audit, ahead: WriteAhead | None = None
    ) -> None:
        self.axes, self.stops, self.audit = axes, stops, audit
        #: writes a call's intent before it acts (None: only the outcome is recorded)
        self.ahead = ahead

    async def call(
        self,
        path: str,
        body: dict[str, Any],
        action: Callable[[str], Awaitable[Any]],
        *,
        motion: bool = False,
        stop: bool = False,
    ) -> Any:
        """Run ``action(holder)`` as the caller, an operator; audited (its intent written
        ahead: ``motion`` fsyncs it by default, a ``stop`` never waits for it); status on
        refusal."""
        began = time.perf_counter()
        user = caller()
        status, result, answer = ua.StatusCodes.Good, "done", None
        intent: int | None = None
        try:
            if user is None or not user.gateway_role.allows(Role.OPERATOR):
                raise StatusRefusal(
                    ua.StatusCodes.BadUserAccessDenied, f"{_who(user)} is not an operator"
                )
            if self.ahead is not None:
                entry = {**_entry(user, path, body), "event": "intent"}
                try:
                    intent = await self.ahead(entry, motion=motion, stop=stop)
                except GatewayError as exc:
                    raise StatusRefusal(
                        ua.StatusCodes.BadResourceUnavailable,
                        f"the audit entry cannot be written, nothing was sent: {exc}",
                    ) from None
            answer = await action(str(user.name))
            result = _said(answer)
        except StatusRefusal as exc:
            status, result = exc.status, str(exc)
        except GatewayError as exc:
            status, result = refusal_status(exc), f"{type(exc).__name__}: {exc}"
        outcome = _entry(user, path, body)
        outcome.update(
            status=ua.StatusCode(status).name,
            duration=round(time.perf_counter() - began, 6),
            result=result,
        )
        if intent is not None:
            outcome["intent"] = intent
        self.audit(outcome)
        if status != ua.StatusCodes.Good:
            raise StatusRefusal(status, result)
        return answer

    # ------------------------------------------------------------------ axes

    async def move(self, axis: str, position: float, unit: str, *, relative: bool) -> str:
        """Start a move; the operation's id."""
        name = "MoveRelative" if relative else "MoveAbsolute"

        async def act(holder: str) -> Any:
            chosen = _choice(Unit, unit, "unit", Unit.USER)
            return await self.axes.move(
                axis, position, relative=relative, unit=chosen, holder=holder
            )

        body = {"position": position, "unit": unit}
        return str((await self._axis_call(axis, name, body, act, motion=True)).id)

    async def home(self, axis: str, method: str) -> str:
        """Start an origin search; the operation's id."""

        async def act(holder: str) -> Any:
            chosen = _choice(HomeMethod, method, "method", HomeMethod.SEARCH_1)
            return await self.axes.home(axis, chosen, holder=holder)

        return str((await self._axis_call(axis, "Home", {"method": method}, act, motion=True)).id)

    async def stop_axis(self, axis: str, mode: str) -> str:
        """Stop the axis's controller; the outcome (done, not_done, unknown)."""

        async def act(holder: str) -> Any:
            chosen = _choice(StopMode, mode, "mode", StopMode.DECELERATE)
            return await self.axes.stop(axis, chosen)

        return str((await self._axis_call(axis, "Stop", {"mode": mode}, act, stop=True)).outcome)

    async def acknowledge(self, axis: str) -> None:
        """Clear the axis's latched errors."""

        async def act(holder: str) -> Any:
            return self.axes.acknowledge(axis, None)

        await self._axis_call(axis, "AcknowledgeErrors", {}, act)

    async def _axis_call(
        self,
        axis: str,
        name: str,
        body: dict[str, Any],
        act: Callable[[str], Awaitable[Any]],
        *,
        motion: bool = False,
        stop: bool = False,
    ) -> Any:
        if motion:
            act = _unless_stopped_since(axis, act)
        return await self.call(f"axes/{axis}/{name}", body, act, motion=motion, stop=stop)

    # ------------------------------------------------------------------ stop-all

    async def stop_controller(self, controller: str, mode: str) -> str:
        """Stop both axes of a controller; the outcome."""

        async def act(holder: str) -> Any:
            chosen = _choice(StopMode, mode, "mode", StopMode.DECELERATE)
            return await self.stops.controller(controller, chosen)

        path = f"controllers/{controller}/Stop"
        result = await self.call(path, {"mode": mode}, act, stop=True)
        return str(result.outcome)

    async def stop_loop(self, loop: str, mode: str) -> str:
        """Stop every controller of a loop; the overall outcome."""

        async def act(holder: str) -> Any:
            chosen = _choice(StopMode, mode, "mode", StopMode.DECELERATE)
            return await self.stops.loop(loop, chosen)

        result = await self.call(f"loops/{loop}/Stop", {"mode": mode}, act, stop=True)
        return str(result.outcome)


def _entry(user: GatewayUser | None, path: str, body: dict[str, Any]) -> dict[str, Any]:
    """What every audit entry of a call says: when, who, what."""
    return {
        "time": _utc(),
        "token": user.name if user else None,
        "role": str(user.gateway_role) if user else None,
        "client": "opcua",
        "method": AUDIT_METHOD,
        "path": path,
        "query": None,
        "body": body,
    }


def _who(user: GatewayUser | None) -> str:
    if user is None:
        return "an unknown session"
    return f"{user.name!r} ({user.gateway_role})"


def _said(answer: Any) -> str:
    for attr in ("outcome", "id"):
        if hasattr(answer, attr):
            return str(getattr(answer, attr))
    return "done"


def _utc() -> str:
    now = time.time()
    stamp = time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(now))
    return f"{stamp}.{int(now % 1 * 1000):03d}Z"


def _unless_stopped_since(
    axis: str, act: Callable[[str], Awaitable[Any]]
) -> Callable[[str], Awaitable[Any]]:
    """``act``, refused when a stop covering ``axis`` was sent on the session after this call
    and overtook it (``call_lanes``): the client asked for the stop last."""

    async def unless_stopped(holder: str) -> Any:
        target = stopped_since_queued(axis)
        if target is not None:
            raise StatusRefusal(
                ua.StatusCodes.BadInvalidState,
                f"a Stop of {target} sent after this call on the session came first: not sent",
            )
        return await act(holder)

    return unless_stopped
