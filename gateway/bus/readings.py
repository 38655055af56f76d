"""What one decoded reply tells the state cache: dispatch on the command's reply format.

``apply_reply`` is the reply half of ``StateCache.observe``; it writes through the cache's
public setters (``StateWriter``, which the cache is), so every field it moves is numbered and
published like any other change, and this module needs nothing of ``gateway.bus.state``.
Reads that clear device flags (``""``, ``9`` form I, ``GSS``) latch what they report here,
or it would be lost (§10 "" 注意点, §10 9 ①, §10 GSS). The framing is not read here: the
scheduler alone decides it (``FramingChanged``, ``gateway.bus.framing_track``), from the
same replies.
"""

from __future__ import annotations

from collections.abc import Iterable
from types import MappingProxyType
from typing import Any, Protocol

from gateway.bus.origin import (
    origin_accepted,
    origin_position,
    origin_program,
    origin_status,
)
from gateway.bus.position_presets import PRESETS_ONE, presets_positions
from gateway.bus.state_types import MOTORS, AxisState, ControllerState, ErrorKind
from gateway.protocol import commands
from gateway.protocol.models import Command
from gateway.protocol.replies import ReplyValue
from gateway.protocol.reply_values import (
    ConditionFlags,
    ProgramState,
    SensorBits,
    StatusFlags,
    Version,
)
from gateway.protocol.spec import Effect

__all__ = ["StateWriter", "apply_reply"]


class StateWriter(Protocol):
    """What a reply is written through (``gateway.bus.state.StateCache``)."""

    #: per controller, the errors ``""`` reported since the last ``9`` form I read
    status_since_condition: dict[tuple[str, str], frozenset[ErrorKind]]

    def flags(self, loop: str, body: str) -> ControllerState:
        """One controller as last changed (its ``updated`` may lag)."""
        ...

    def axis(self, loop: str, body: str, motor: int) -> AxisState:
        """One axis."""
        ...

    def axis_flags(self, loop: str, body: str, motor: int) -> AxisState:
        """One axis as last changed (its ``updated`` may lag)."""
        ...

    def write_controller(self, now: float, loop: str, body: str, **values: Any) -> None:
        """Set fields of one controller."""
        ...

    def controller_reset(
        self, now: float, loop: str, body: str, cause: str, *, read: int | None = None
    ) -> None:
        """A reset of controller ``body`` was seen (``gateway.bus.origin``)."""
        ...

    def write_axis(self, now: float, loop: str, body: str, motor: int, **values: Any) -> None:
        """Set fields of one axis."""
        ...

    def latch(
        self, now: float, loop: str, body: str, kinds: Iterable[ErrorKind], source: str
    ) -> None:
        """Latch the errors ``kinds`` the reply to ``source`` reported."""
        ...


_STATUS_KINDS = {"limit_error": ErrorKind.LIMIT, "emergency_stop": ErrorKind.EMERGENCY}
_STATUS_KINDS["command_error"] = ErrorKind.COMMAND


def apply_reply(
    cache: StateWriter,
    loop: str,
    body: str,
    command: Command,
    value: ReplyValue | None,
    now: float,
    *,
    motor: int | None,
    rejected: bool,
) -> None:
    """Store what the reply ``value`` of ``body`` to ``command`` tells (see ``observe``)."""
    _Reading(cache, loop, body, command, now, motor).apply(value, rejected)


class _Reading:
    """What one reply tells: dispatch on the command's reply format and form."""

    def __init__(
        self,
        cache: StateWriter,
        loop: str,
        body: str,
        command: Command,
        now: float,
        hint: int | None,
    ) -> None:
        self.cache, self.loop, self.body, self.command, self.now = cache, loop, body, command, now
        self.hint = hint  # the scheduler's motor for a command without a suffix

    def motor(self, ctl: ControllerState) -> int | None:
        """The motor the command acted on: its suffix, else the selection (§10 F)."""
        return self.command.motor or self.hint or ctl.selected_motor

    def ctl(self, **values: Any) -> None:
        self.cache.write_controller(self.now, self.loop, self.body, **values)

    def axis(self, motor: int, **values: Any) -> None:
        self.cache.write_axis(self.now, self.loop, self.body, motor, **values)

    def latch(self, kinds: Iterable[ErrorKind]) -> None:
        self.cache.latch(self.now, self.loop, self.body, kinds, self.command.key)

    def apply(self, value: ReplyValue | None, rejected: bool) -> None:
        ctl = self.cache.flags(self.loop, self.body)
        self.ctl(online=True, updated=self.now)
        if value is None and not rejected:  # '>' (a '>@' changed nothing, §10 ER)
            self.accepted(ctl)
        elif isinstance(value, StatusFlags):
            self.status(ctl, value)
        elif isinstance(value, ConditionFlags):
            self.condition(ctl, value)
        elif isinstance(value, ProgramState):
            self.ctl(program=value)
            origin_program(self.cache, self.loop, self.body, value, self.now)
            if value is ProgramState.ERROR:  # GSS: reading E clears it to 0 (§10 GSS)
                self.latch([ErrorKind.PROGRAM])
        elif isinstance(value, Version):
            self.ctl(version=value)
        elif isinstance(value, SensorBits):
            motor = self.motor(ctl)  # CL: the selected (or moving) motor
            if motor is not None:
                self.axis(motor, sensors=value)
        elif isinstance(value, int) and not isinstance(value, bool):
            self.number(ctl, value)

    def accepted(self, ctl: ControllerState) -> None:
        form = self.command.form
        origin_accepted(self.cache, self.loop, self.body, self.command, self.motor(ctl), self.now)
        if form is commands.SELECT_MOTOR and not ctl.moving:  # not while moving (§10 F)
            self.ctl(selected_motor=self.command.motor, selection_confirmed=False)
        elif form.effect is Effect.MOTION and not ctl.moving:
            # A suffix selects the motor and the selection stays (§9-1, §10 F).
            # Moving from the '>' on, until a status read says otherwise: a per-motor command
            # for the other motor must wait, its F would be refused (§10 F).
            moved = self.motor(ctl)
            confirmed = ctl.selection_confirmed and moved == ctl.selected_motor
            self.ctl(
                selected_motor=moved, last_moved=moved, selection_confirmed=confirmed, moving=True
            )
        elif form is commands.SET_SIGNED_POSITIONS or form is commands.SET_UNSIGNED_POSITIONS:
            self.ctl(signed_positions=form is commands.SET_SIGNED_POSITIONS)
        elif form is commands.LOAD_SETTINGS:  # the settings, EP among them, reloaded (§10 DL)
            self.ctl(signed_positions=None)
        if presets_positions(self.command):
            self.positions_unknown(ctl)

    def positions_unknown(self, ctl: ControllerState) -> None:
        """A position changed without motion (``position_presets``): stale until read back."""
        motor = self.motor(ctl) if self.command.form in PRESETS_ONE else None
        for m in MOTORS if motor is None else (motor,):
            self.axis(m, stale=True)

    def status(self, ctl: ControllerState, flags: StatusFlags) -> None:
        # "" clears bits 1-3 after the reply (§10 "" 注意点): latch them now or lose them.
        if flags.moving and ctl.selection_confirmed and ctl.selected_motor is not None:
            self.ctl(last_moved=ctl.selected_motor)  # the moving motor is the selected one
        self.ctl(status=flags, moving=flags.moving)
        kinds = {k for name, k in _STATUS_KINDS.items() if getattr(flags, name)}
        self.latch(kinds)
        # The condition store keeps these until a 9 form I read (§10 9 ③): not new then.
        if kinds:
            seen = self.cache.status_since_condition
            seen[self.loop, self.body] = seen.get((self.loop, self.body), frozenset()) | kinds
        for m in MOTORS:
            # An axis whose position was never read stays stale: nothing is claimed unread.
            unread = self.cache.axis_flags(self.loop, self.body, m).position is None
            self.axis(m, updated=self.now, stale=unread)
        origin_status(self.cache, self.loop, self.body, flags, self.now)

    def condition(self, ctl: ControllerState, flags: ConditionFlags) -> None:
        # 9 form I clears bits 0-3 after the reply (§10 9 ①); bit 6 stays (§10 9 ⑤).
        bits = dict(ctl.condition_bits)
        bits.update({0: 0, 1: 0, 2: 0, 3: 0, 6: int(flags.step_out)})
        bits.update({4: flags.mode, 5: flags.mode, 7: flags.selected_motor - 1})
        self.ctl(
            condition=flags,
            mode=flags.mode,
            selected_motor=flags.selected_motor,
            selection_confirmed=True,
            condition_bits=MappingProxyType(bits),
        )
        # Bits 1-3 that "" already reported since the last form I read are the same errors
        # again (two stores of one event, §10 9 ③), not new ones: latched once.
        reported = self.cache.status_since_condition.pop((self.loop, self.body), frozenset())
        kinds = [
            k for name, k in _STATUS_KINDS.items() if getattr(flags, name) and k not in reported
        ]
        self.latch([ErrorKind.COMMUNICATION] * flags.communication_error + kinds)

    def number(self, ctl: ControllerState, value: int) -> None:
        form = self.command.form
        if form.reads_position:
            motor = self.motor(ctl)
            if motor is not None:
                origin_position(self.cache, self.loop, self.body, motor, value, self.now)
        elif form is commands.CONDITION_BIT:
            self.condition_bit(ctl, int(self.command.params()["bit"]), value)
        elif form is commands.MODE:
            self.ctl(mode=value)
        elif form is commands.POSITION_FORMAT and value in (0, 1):
            self.ctl(signed_positions=value == 1)
        elif form is commands.SELECTED_MOTOR:
            self.ctl(selected_motor=value, selection_confirmed=True)

    def condition_bit(self, ctl: ControllerState, bit: int, value: int) -> None:
        # 9{bit} clears nothing (§10 9 ②): the device holds a set bit until a 9 form I read,
        # so only a 0 -> 1 change is a new communication error. Bits 1-3 repeat what the
        # status flags (polled with "") report, in their own store: not latched again.
        was = ctl.condition_bits.get(bit)
        self.ctl(condition_bits=MappingProxyType({**ctl.condition_bits, bit: value}))
        if bit == 0 and value and was != 1:
            self.latch([ErrorKind.COMMUNICATION])
        elif bit in (4, 5):
            self.ctl(mode=value)
        elif bit == 7:
            self.ctl(selected_motor=value + 1, selection_confirmed=True)
