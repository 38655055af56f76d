"""A jog toward a soft limit, as an EPICS motor record does it: a move to the limit.

On a side of an axis with a soft limit, ``7``/``8`` would run past it until a sensor or a
stop. Instead the jog is a move to the limit (``2{limit}`` + ``3``, §10 2, 3) at the jog
speed, ended by a stop like any jog (and ``done`` when it reaches the limit):

* High speed: the move's own speed is OH, the speed ``H`` raises a jog to (§10 H).
* Low speed: a ``3`` move runs at OH, so OH is set to OL for it (``OH{OL}`` in the same
  transaction) and given back when the operation ends (``OH{old}``). If the loop is down then,
  OH stays at OL and a warning is logged.

The speed of such a jog cannot change while it runs (``H``/``L`` act on ``7``/``8`` only).
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable

from gateway.bus.requests import TransactionResult
from gateway.errors import DeviceError, InvalidInputError
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.service.axes.position_format import check_target, position_data
from gateway.service.operations.asked import JogAsked
from gateway.service.operations.book import Operation
from gateway.service.operations.terms import Direction, JogSpeed
from gateway.service.topology import AxisRef

__all__ = ["LimitJogs"]

log = logging.getLogger("gateway.service")

#: ``AxisService._run``: run commands as an operation.
Run = Callable[..., Awaitable[Operation]]
#: ``AxisService._submit``: one transaction.
Submit = Callable[..., Awaitable[TransactionResult]]

JOG_RULE = (
    "a jog on an axis with soft limits moves toward the limit in its direction (soft limits; "
    "in unsigned management no position below 0, §10 EP, §7-4)"
)


class LimitJogs:
    """Starts jogs toward a soft limit and gives OH back after the low-speed ones."""

    def __init__(self, run: Run, submit: Submit) -> None:
        self._run = run
        self._submit = submit
        self._background: set[asyncio.Future[None]] = set()

    async def start(
        self,
        ref: AxisRef,
        asked: JogAsked,
        current: int,
        limit: int,
        fmt: PositionFormat,
        holder: str,
    ) -> Operation:
        """The jog ``asked`` on ``ref`` (at ``current`` pulses) as a move to ``limit``."""
        cw = asked.direction is Direction.CW
        if (cw and current >= limit) or (not cw and current <= limit):
            raise InvalidInputError(
                f"axis {ref.id} is at {current} pulses, at or beyond its limit {limit} in the "
                f"{asked.direction.value} direction; nothing was sent",
                field="direction",
                rule=JOG_RULE,
            )
        check_target(ref, limit, fmt)
        moves: list[Command] = [position_data(limit, fmt), cmd.move_to_position_data()]
        if asked.speed is JogSpeed.HIGH:
            return await self._run(ref, asked, moves, target=limit, holder=holder)
        result = await self._submit(ref, [cmd.speed("OH"), cmd.speed("OL")], motor=ref.motor)
        oh, ol = (r.value for r in result.results[-2:])
        if not isinstance(oh, int) or not isinstance(ol, int):
            raise DeviceError(f"OH and OL of {ref.id} could not be read", outcome="not_done")
        commands = [cmd.set_speed("OH", ol), *moves]
        try:
            op = await self._run(ref, asked, commands, target=limit, holder=holder)
        except BaseException:
            self._give_back(ref, oh, None)
            raise
        self._give_back(ref, oh, op)
        return op

    def _give_back(self, ref: AxisRef, oh: int, op: Operation | None) -> None:
        """Set OH back once ``op`` has ended (at once without one)."""

        async def give_back() -> None:
            if op is not None:
                await op.finished.wait()
            try:
                await self._submit(ref, [cmd.set_speed("OH", oh)], motor=ref.motor)
            except Exception as exc:  # the loop went down: OH stays at OL; say so
                log.warning("OH of %s could not be set back to %d: %s", ref.id, oh, exc)

        task = asyncio.ensure_future(give_back())
        self._background.add(task)
        task.add_done_callback(self._background.discard)
