"""Axes as users act on them: move, home, jog, step, stop, speed, errors.

Every check a request can fail is made before anything is sent: the lease (the axis and its
controller), the controller online and not moving (§2: its two motors never move together; a
motion command while one moves is ignored with a command error, §9-1 注意), units, the soft
limits and the position counter (§7-4), and first of all remote control (a controller in
local control refuses motion and settings from the network, ``gateway.service.control``).
Stops skip all of it: **a stop is never refused**.

Commands (§10, as the catalog defines them; per-motor commands go with ``motor=`` and the
scheduler sends ``F`` when the selection differs):

=============== =====================================================================
move absolute   ``2{pp}`` then ``3`` (position data, then move to it)
move relative   ``2{|d|}`` then ``4`` (CW, d > 0) or ``5`` (CCW, d < 0)
home            ``0`` / ``0A`` / ``0H`` / ``0R``; ``0Z`` has no motor form: ``F{mt}`` first
jog             ``7`` (CW) / ``8`` (CCW) at Low speed, then ``H`` for High speed (§10 H);
                a jog already running in that direction only gets ``H`` / ``L``. Toward a
                soft limit: ``2{limit}`` + ``3`` (High), ``OH{OL}`` + ``2{limit}`` + ``3``
                then ``OH`` back (Low), ended by a stop like any jog
step            ``7*`` / ``8*`` (one pulse)
stop            ``S`` immediate, ``SS`` decelerate to Low speed then stop (§10 S, SS)
=============== =====================================================================
"""

from __future__ import annotations

from collections.abc import Mapping

from gateway.bus.requests import TransactionResult
from gateway.bus.state_types import ErrorKind
from gateway.errors import ConflictError, DeviceError, InvalidInputError
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.params import UNSIGNED_MAX
from gateway.protocol.speeds import SpeedSettings
from gateway.service.axes.limit_jog import LimitJogs
from gateway.service.axes.origin_guard import OriginGuard, needs_origin, reading_is_current
from gateway.service.axes.position_format import (
    PositionFormats,
    check_absolute_from,
    check_target,
    position_data,
)
from gateway.service.axes.soft_limits import has_soft_limits, jog_limit
from gateway.service.axes.speeds import (
    QUERIES,
    QUERIES_WHILE_MOVING,
    SpeedView,
    settings_from,
    speed_view,
    update_commands,
)
from gateway.service.leases import Leases
from gateway.service.operations.asked import Asked, HomeAsked, JogAsked, MoveAsked, StepAsked
from gateway.service.operations.book import Operation, Operations
from gateway.service.operations.terms import (
    Direction,
    HomeMethod,
    JogSpeed,
    StopMode,
    StopResult,
    Unit,
)
from gateway.service.presend import PreSendChecks
from gateway.service.runtime.runtime import Runtime
from gateway.service.stops import STOP_COMMANDS
from gateway.service.topology import AxisRef
from gateway.service.views import AxisView, axis_view

__all__ = [
    "AxisService",
    "Direction",
    "HomeMethod",
    "JogSpeed",
    "StopMode",
    "StopResult",
    "Unit",
]


_JOG = {Direction.CW: cmd.jog_cw, Direction.CCW: cmd.jog_ccw}
_STEP = {Direction.CW: cmd.step_cw, Direction.CCW: cmd.step_ccw}
_HOME: dict[HomeMethod, cmd.HomeMethod] = {
    HomeMethod.SEARCH_1: "0",
    HomeMethod.HIGH_2: "0A",
    HomeMethod.HIGH_1: "0H",
    HomeMethod.SEARCH_2: "0R",
    HomeMethod.Z_PHASE: "0Z",
}


class AxisService:
    """Every action on an axis; the API's routes call these."""

    def __init__(self, runtime: Runtime, operations: Operations, leases: Leases) -> None:
        self.runtime = runtime
        self.operations = operations
        self.checks = PreSendChecks(runtime, leases)
        self.formats = PositionFormats(runtime)
        self.origins = OriginGuard(runtime)
        self._speeds: dict[str, SpeedSettings] = {}  # last read, per axis id (OC while moving)
        self._limit_jogs = LimitJogs(self._run, self._submit)

    # ------------------------------------------------------------------ reading

    def ref(self, ident: str) -> AxisRef:
        """The axis with id or name ``ident`` (``NotFoundError`` otherwise)."""
        return self.runtime.topology.axis(ident)

    def view(self, ident: str) -> AxisView:
        """The cached view of one axis (no line traffic)."""
        ref = self.ref(ident)
        return self._view(ref)

    def views(self) -> list[AxisView]:
        """Every axis, cached."""
        return [self._view(a) for a in self.runtime.topology.axes()]

    def _view(self, ref: AxisRef) -> AxisView:
        state = self.runtime.state.axis(ref.loop, ref.body, ref.motor)
        controller = self.runtime.topology.controller(ref.controller_id)
        return axis_view(ref, state, self.runtime.control.view(controller))

    async def fresh(self, ident: str) -> AxisView:
        """Read status and position now (``""``, ``6{mt}``) and return the new view."""
        ref = self.ref(ident)
        await self._submit(ref, [cmd.status(), cmd.position(ref.motor)], motor=None)
        return self.view(ref.id)

    def position(self, ident: str) -> int | None:
        """The cached position of an axis in pulses."""
        ref = self.ref(ident)
        return self.runtime.state.axis(ref.loop, ref.body, ref.motor).position

    # ------------------------------------------------------------------ motion

    async def move(
        self, ident: str, position: float, *, relative: bool, unit: Unit, holder: str
    ) -> Operation:
        """Move to ``position`` (or by it, ``relative``) in pulses or the axis's user unit."""
        ref = self.ref(ident)
        self._may_act(ref, holder)
        if unit is Unit.USER:
            value = ref.to_pulses(position, "position")
        elif float(position).is_integer():
            value = int(position)
        else:
            raise InvalidInputError(
                f"{position} is not a whole number of pulses",
                field="position",
                rule="a position in pulses is a whole number",
            )
        if abs(value) > UNSIGNED_MAX:  # no counter holds it: refused before anything is read
            raise InvalidInputError(
                f"{position} is {value} pulses, beyond the 24-bit position counter",
                field="position",
                rule=f"at most {UNSIGNED_MAX} pulses either way (§10 EP)",
            )
        if relative and value == 0:
            raise InvalidInputError(
                "a relative move of 0 pulses",
                field="position",
                rule="|distance| >= 1 pulse",
            )
        fmt = await self.formats.get(ref.loop, ref.body)
        here: int | None = None
        if needs_origin(ref, absolute_user=unit is Unit.USER and not relative):
            here = await self.origins.confirm(ref, "move")
        if relative:
            target = (here if here is not None else await self._current(ref)) + value
        else:
            target = value
            check_absolute_from(ref, here if here is not None else self._cached(ref), fmt)
        check_target(ref, target, fmt)
        if relative:
            moves = [position_data(abs(value), fmt), cmd.move_cw() if value > 0 else cmd.move_ccw()]
        else:
            moves = [position_data(target, fmt), cmd.move_to_position_data()]
        asked = MoveAsked(position=position, relative=relative, unit=unit)
        step = value if relative else None
        return await self._run(ref, asked, moves, target=target, step=step, holder=holder)

    async def home(self, ident: str, method: HomeMethod, *, holder: str) -> Operation:
        """Search the origin with ``method``; the position is 0 there (§10 0 ... 0Z)."""
        ref = self.ref(ident)
        self._may_act(ref, holder)
        if method is HomeMethod.Z_PHASE:  # 0Z acts on the selected motor, no MT form (§10 0Z)
            commands = [cmd.select_motor(ref.motor), cmd.home("0Z")]
        else:
            commands = [cmd.home(_HOME[method])]
        return await self._run(ref, HomeAsked(method=method), commands, target=0, holder=holder)

    async def jog(
        self, ident: str, direction: Direction, speed: JogSpeed, *, holder: str
    ) -> Operation:
        """Turn until stopped (or a limit): ``7``/``8`` at Low speed, ``H`` for High. On a
        side with a soft limit, a move to that limit at the jog speed (``_jog_to_limit``)."""
        ref = self.ref(ident)
        self.checks.axis_lease(ref, holder)
        active = self.operations.active(ref.loop, ref.body)
        if (
            active is not None
            and isinstance(running := active.asked, JogAsked)
            and active.axis.id == ref.id
            and running.direction is direction
        ):
            if active.target is not None:  # a move to the soft limit: its speed is fixed
                if running.speed is speed:
                    return active
                raise ConflictError(
                    f"the jog of {ref.id} runs as a move to its soft limit; its speed cannot "
                    "change while it runs (H, L act on 7/8 only, §10 H, L): stop it first",
                    field="speed",
                )
            # The same jog: only its speed changes (§10 H, L work while turning); a setting
            # from the network, refused in local control like any other.
            self.checks.remote(ref, "change the jog speed of")
            jog_speed = cmd.jog_high() if speed is JogSpeed.HIGH else cmd.jog_low()
            await self._submit(ref, [jog_speed], motor=None)
            active.asked = running.model_copy(update={"speed": speed})
            return active
        self._may_act(ref, holder)
        asked = JogAsked(direction=direction, speed=speed)
        if has_soft_limits(ref):
            fmt = await self.formats.get(ref.loop, ref.body)
            current = await self.origins.confirm(ref, "jog")
            limit = jog_limit(ref, direction is Direction.CW, fmt)
            if limit is not None:
                return await self._limit_jogs.start(ref, asked, current, limit, fmt, holder)
        commands = [_JOG[direction]()]
        if speed is JogSpeed.HIGH:
            commands.append(cmd.jog_high())
        return await self._run(ref, asked, commands, holder=holder)

    async def step(self, ident: str, direction: Direction, *, holder: str) -> Operation:
        """Move one pulse (``7*`` / ``8*``), inside the soft limits."""
        ref = self.ref(ident)
        self._may_act(ref, holder)
        fmt = await self.formats.get(ref.loop, ref.body)
        here = await self.origins.confirm(ref, "step") if has_soft_limits(ref) else None
        here = here if here is not None else await self._current(ref)
        target = here + (1 if direction is Direction.CW else -1)
        check_target(ref, target, fmt)
        commands = [_STEP[direction]()]
        step = 1 if direction is Direction.CW else -1
        asked = StepAsked(direction=direction)
        return await self._run(ref, asked, commands, target=target, step=step, holder=holder)

    async def stop(self, ident: str, mode: StopMode) -> StopResult:
        """Stop: never refused (no lease, moving or state check). ``S``/``SS`` act on the
        selected motor, which is the moving one (``F`` is refused while moving, §10 F)."""
        ref = self.ref(ident)
        command = STOP_COMMANDS[mode]
        op = self.operations.note_stop(ref.loop, ref.body)
        result = await self.runtime.scheduler(ref.loop).stop(ref.body, command)
        return StopResult(
            axis=ref.id,
            command=command.wire(),
            outcome=result.outcome,
            frames=result.frames,
            operation=op.id if op is not None else None,
        )

    # ------------------------------------------------------------------ speed

    async def speed(self, ident: str) -> SpeedView:
        """Read OH, OL, OS, OC and OX; OC only while stopped (§10 OC), else the last read."""
        ref = self.ref(ident)
        ctl = self.runtime.state.controller(ref.loop, ref.body)
        moving = bool(ctl.moving)
        if moving and ctl.selected_motor != ref.motor:
            # OH, OL, OS, OC are per motor: reading motor m's needs F{m}, and F is refused
            # while a motor moves (§10 F). The moving motor is the selected one.
            other = "another motor" if ctl.selected_motor is None else f"motor {ctl.selected_motor}"
            raise ConflictError(
                f"the speed data of {ref.id} cannot be read while {other} of controller "
                f"{ref.controller_id} moves: motor {ref.motor} cannot be selected then "
                "(§10 F); read it when the motion has ended",
                field="axis",
            )
        names = QUERIES_WHILE_MOVING if moving else QUERIES
        known = self._speeds.get(ref.id)
        if moving and known is None:
            raise ConflictError(
                f"controller {ref.controller_id} is moving and OC of {ref.id} was never read: "
                "OC cannot be read while a motor moves (§10 OC)",
                field="oc",
            )
        result = await self._submit(ref, [cmd.speed(n) for n in names], motor=ref.motor)
        settings = settings_from(result, names, known.oc if known else None)
        self._speeds[ref.id] = settings
        return speed_view(ref.id, settings, oc_cached=moving)

    async def set_speed(self, ident: str, change: Mapping[str, int], *, holder: str) -> SpeedView:
        """Set the speed data given (``oh``, ``ol``, ``os``, ``oc``, ``ox``) after checking
        ranges and the S-curve rule (§7-1), then read them back."""
        ref = self.ref(ident)
        self._may_act(ref, holder, what="change the speed of")
        current = await self.speed(ref.id)
        now = SpeedSettings(current.oh, current.ol, current.os, current.oc, current.ox)
        _, commands = update_commands(now, change)
        reads = [cmd.speed(n) for n in QUERIES]
        result = await self._submit(ref, [*commands, *reads], motor=ref.motor)
        settings = settings_from(result, QUERIES)
        self._speeds[ref.id] = settings
        view = speed_view(ref.id, settings)
        view.frames = [r.written for r in result.results[: len(commands)] if r.frame]
        return view

    # ------------------------------------------------------------------ errors

    def acknowledge(self, ident: str, kinds: list[ErrorKind] | None) -> AxisView:
        """The client has seen the axis's latched errors (those of ``kinds``; all if None)."""
        ref = self.ref(ident)
        now = self.runtime.scheduler(ref.loop).clock()
        self.runtime.state.acknowledge(ref.loop, ref.body, now, motor=ref.motor, kinds=kinds)
        return self.view(ref.id)

    # ------------------------------------------------------------------ helpers

    def _prefix(self, ref: AxisRef) -> str:
        return self.runtime.topology.controller(ref.controller_id).series.value

    def _may_act(self, ref: AxisRef, holder: str, what: str = "move") -> None:
        """Every check before an action on ``ref`` (``PreSendChecks.axis_action``)."""
        self.checks.axis_action(ref, holder, self.operations.active(ref.loop, ref.body), what)

    def _cached(self, ref: AxisRef) -> int | None:
        """The axis's position if the cached reading is current (``reading_is_current``)."""
        state = self.runtime.state.axis(ref.loop, ref.body, ref.motor)
        return state.position if reading_is_current(state) else None

    async def _current(self, ref: AxisRef) -> int:
        """The axis's position: cached when current, else read now (the state cache follows
        the counter through its wraps, ``gateway.bus.counting``)."""
        cached = self._cached(ref)
        if cached is not None:
            return cached
        result = await self._submit(ref, [cmd.position(ref.motor)], motor=None)
        position = self.runtime.state.axis(ref.loop, ref.body, ref.motor).position
        if not isinstance(result.value, int) or position is None:
            raise DeviceError(f"the position of {ref.id} could not be read", outcome="not_done")
        return position

    async def _submit(
        self, ref: AxisRef, commands: list[Command], *, motor: int | None
    ) -> TransactionResult:
        return await self.runtime.scheduler(ref.loop).submit(ref.body, commands, motor=motor)

    async def _run(
        self,
        ref: AxisRef,
        asked: Asked,
        commands: list[Command],
        *,
        target: int | None = None,
        step: int | None = None,
        holder: str,
    ) -> Operation:
        return await self.operations.run(
            ref,
            asked,
            commands,
            motor=ref.motor,
            target=target,
            step=step,
            prefix=self._prefix(ref),
            holder=holder,
        )
