"""Soft limits on every path that can move an axis: ``/commands``, ``/raw`` and jog.

The axis routes check a move's target before sending (``check_target``). A client can also
move an axis with any motion command of the catalog (``/commands``, ``/raw``); on an axis
with soft limits each is turned into a known target first, checked, and sent so that nothing
can change that target between the check and the motion (§10 2, 3, 4, 5, A, B, B+(-)):

============================ ===============================================================
command                      target, and what is sent
============================ ===============================================================
``3`` / ``3{mt}``            the position data, read with ``2D``; ``2{pp}`` (the value read)
                             is written again in the same transaction, then ``3``
``4`` / ``5`` (+ ``{mt}``)   position -/+ |position data| (``2D``; §10 4, 5 use the count,
                             docs/manual-notes.md "Pulse counts"), ``2{pp}`` again, then 4/5
``B{pn}`` / ``B{pn}{mt}``    table entry ``A{pn}D``; ``A{pn}{pp}`` again, then ``B``
``B{pn}{dir}`` (+ ``{mt}``)  position ± |A[pn]| (§10 B+(-) 注意点); ``A{pn}{pp}`` again, then B
``1`` / ``1{mt}``            0 (electrical origin, §10 1)
``7*`` / ``8*``              position ± 1
origin searches (``0`` ...)  allowed: they end at the origin, where the position is 0
``7``/``8``, sequential      refused: no target the gateway can know before sending (a jog
``B``, ``B{dir}``            runs until stopped: use ``POST /axes/{id}/jog``; sequential B
                             continues a pointer the device keeps: give the entry number)
============================ ===============================================================

The axis is the command's motor suffix, else the ``motor`` of the request, else the selected
motor as cached; the motor found is handed to the scheduler so that the motor checked is the
motor that moves. "Position" is read with ``6{mt}`` first (``origin_guard``: a reset shows
there, and a lost origin refuses the command 409 "home first"). Targets
beyond the soft limits, the position counter or the controller's format (EP0: no negative
target) are 422 naming the rule; nothing is sent. Axes without soft limits are not touched.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from gateway.bus.counting import target_range
from gateway.errors import DeviceError, InvalidInputError
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.protocol.spec import Effect
from gateway.service.axes.origin_guard import OriginGuard
from gateway.service.axes.position_format import PositionFormats, check_target, position_data
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import AxisRef, ControllerRef

__all__ = ["Guarded", "SoftLimits", "has_soft_limits", "jog_limit"]

#: Rule text of a motion command whose target the gateway cannot know before it is sent.
UNKNOWN_TARGET_RULE = (
    "on an axis with soft limits a motion command must have a target known before it is "
    "sent: 2 then 3, 4, 5, B{pn}, B{pn}+/-, 1, 7*, 8*, origin searches; a jog (7, 8) goes "
    "through POST /axes/{id}/jog (it stops at the soft limit), sequential B needs the entry "
    "number"
)


def has_soft_limits(axis: AxisRef) -> bool:
    """Whether the axis has a soft limit on either side."""
    return axis.soft_min is not None or axis.soft_max is not None


def jog_limit(axis: AxisRef, cw: bool, fmt: PositionFormat) -> int | None:
    """Where a jog CW (``cw``) or CCW must end on ``axis``, in pulses; None when that side
    has no soft limit (the jog then runs until stopped, §10 7, 8).

    The nearest whole pulse inside the limit; CCW in unsigned management (EP0) never below 0,
    where position management breaks (§7-4, §10 EP)."""
    limit = axis.soft_max if cw else axis.soft_min
    if limit is None:
        return None
    pulses = limit / axis.units_per_pulse
    low, high = target_range(fmt)
    if cw:
        return min(math.floor(pulses + 1e-6), high)
    return max(math.ceil(pulses - 1e-6), low)


@dataclass(frozen=True)
class Guarded:
    """What to send after the soft-limit check: the commands and the motor for ``F``."""

    commands: list[Command]
    motor: int | None


class SoftLimits:
    """Resolves and checks the target of motion commands sent by ``/commands`` and ``/raw``."""

    def __init__(self, runtime: Runtime) -> None:
        self.runtime = runtime
        self.formats = PositionFormats(runtime)
        self.origins = OriginGuard(runtime)

    async def guard(
        self, ref: ControllerRef, commands: Sequence[Command], motor: int | None, field: str
    ) -> Guarded:
        """The commands to send in place of ``commands`` (module docstring); 422 naming the
        rule when a motion's target is outside the axis's soft limits or cannot be known."""
        moving = [c for c in commands if c.form.effect is Effect.MOTION]
        if not moving:
            return Guarded(list(commands), motor)
        out: list[Command] = []
        for command in commands:
            if command.form.effect is not Effect.MOTION:
                out.append(command)
                continue
            axis = self._axis(ref, command, motor, field)
            if axis is None or not has_soft_limits(axis):
                out.append(command)
                continue
            if command.motor is None:
                motor = axis.motor  # the scheduler selects the motor that was checked
            out.extend(await self._resolved(axis, command, field))
        return Guarded(out, motor)

    def _axis(
        self, ref: ControllerRef, command: Command, motor: int | None, field: str
    ) -> AxisRef | None:
        number = command.motor or motor
        if number is None:
            number = self.runtime.state.controller(ref.loop, ref.body).selected_motor
        if number is None:
            if any(has_soft_limits(a) for a in ref.axes):
                raise InvalidInputError(
                    f"{command.wire()!r}: the motor it would move is not known (the selection "
                    f"of {ref.id} was not read yet), and an axis of {ref.id} has soft limits",
                    field=field,
                    rule="name the motor (`motor`, or the command's motor suffix) so that its "
                    "soft limits can be checked",
                )
            return None
        return ref.axes[number - 1]

    async def _resolved(self, axis: AxisRef, command: Command, field: str) -> list[Command]:
        form = command.form
        if form in cmd.ORIGIN_SEARCHES:
            return [command]
        # The origin must be known, and the position no older than the last reset: read it.
        here = await self.origins.confirm(axis, f"send {command.wire()!r} to", field)
        fmt = await self.formats.get(axis.loop, axis.body)
        if form in cmd.MOVES_TO_ORIGIN:
            self._check(axis, 0, fmt, command, field)
            return [command]
        if form in cmd.ONE_PULSE_STEPS:
            target = here + cmd.ONE_PULSE_STEPS[form]
            self._check(axis, target, fmt, command, field)
            return [command]
        if form in cmd.MOVES_TO_POSITION_DATA or form in cmd.MOVES_BY_POSITION_DATA:
            data = await self._read(axis, cmd.position_data(), "the position data (2D)")
            if form in cmd.MOVES_TO_POSITION_DATA:
                target = data
            else:
                target = here + cmd.MOVES_BY_POSITION_DATA[form] * abs(data)
            self._check(axis, target, fmt, command, field)
            return [position_data(data, fmt), command]
        if form in cmd.MOVES_TO_TABLE_ENTRY or form in cmd.MOVES_BY_TABLE_ENTRY:
            pn = int(command.params()["pn"])
            entry = await self._read(axis, cmd.table_entry(pn), f"position table entry {pn:03d}")
            if form in cmd.MOVES_TO_TABLE_ENTRY:
                target = entry
            else:
                sign = 1 if command.params()["dir"] == "+" else -1
                target = here + sign * abs(entry)
            self._check(axis, target, fmt, command, field)
            signed = fmt is PositionFormat.SIGNED
            return [cmd.set_table_entry(pn, entry, fmt, signed=signed), command]
        raise InvalidInputError(
            f"{command.wire()!r} on axis {axis.id}: the gateway cannot know where it ends, and "
            f"the axis has soft limits",
            field=field,
            rule=UNKNOWN_TARGET_RULE,
        )

    @staticmethod
    def _check(
        axis: AxisRef, target: int, fmt: PositionFormat, command: Command, field: str
    ) -> None:
        try:
            check_target(axis, target, fmt)
        except InvalidInputError as exc:
            raise InvalidInputError(
                f"{command.wire()!r} would move axis {axis.id} to {target} pulses: {exc}",
                field=field,
                rule=exc.rule,
            ) from None

    async def _read(self, axis: AxisRef, query: Command, what: str) -> int:
        scheduler = self.runtime.scheduler(axis.loop)
        result = await scheduler.submit(axis.body, [query], motor=None)
        value = result.value
        if not isinstance(value, int) or isinstance(value, bool):
            raise DeviceError(
                f"{what} could not be read, so the soft limits of {axis.id} cannot be checked; "
                "nothing was sent",
                outcome="not_done",
            )
        return value
