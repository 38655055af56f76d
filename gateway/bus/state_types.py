"""The records of the state cache: loops, controllers, axes, latched errors and changes.

All frozen: the cache replaces a record whenever a field moves, so a record a reader holds
never changes under it (``gateway.bus.state`` builds them, and numbers and publishes the
changes).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType
from typing import Any

from gateway.protocol.framing import Framing
from gateway.protocol.reply_values import (
    ConditionFlags,
    ProgramState,
    SensorBits,
    StatusFlags,
    Version,
)

__all__ = [
    "AXIS_ERRORS",
    "MOTORS",
    "AxisState",
    "Change",
    "ControllerState",
    "ErrorKind",
    "Latch",
    "LoopState",
    "Origin",
    "Snapshot",
]

MOTORS = (1, 2)


class ErrorKind(StrEnum):
    """An error a read reports once and clears on the device (§10 "", §10 9, §10 GSS)."""

    LIMIT = "limit_error"  # "" bit 1, 9 bit 1
    EMERGENCY = "emergency_stop"  # "" bit 2, 9 bit 2
    COMMAND = "command_error"  # "" bit 3, 9 bit 3
    COMMUNICATION = "communication_error"  # 9 bit 0 only: noise or receive overflow
    PROGRAM = "program_error"  # GSS 'E': a user program ended by a command error


#: Errors shown on the axes as well as on the controller.
AXIS_ERRORS = (ErrorKind.LIMIT, ErrorKind.EMERGENCY, ErrorKind.COMMAND)


@dataclass(frozen=True)
class Latch:
    """One latched error of a controller, held until acknowledged."""

    kind: ErrorKind
    #: the motors whose axis still shows it (empty for controller-only kinds)
    axes: frozenset[int]
    first: float  # when a read first reported it
    last: float  # when a read last reported it
    count: int  # how many reads reported it since it was latched
    source: str  # the command (form key) whose reply reported it last, e.g. '""'


class Origin(StrEnum):
    """Whether the counter's 0 is the machine's origin (DESIGN invariant 16)."""

    UNKNOWN = "unknown"  # no origin search seen since the gateway started
    HOMED = "homed"  # an origin search seen to end, no reset since
    LOST = "lost"  # a controller reset seen: the counter restarted at 0 where the axis stood


@dataclass(frozen=True)
class AxisState:
    """One motor of one controller as the gateway last saw it."""

    motor: int
    #: pulses: the counter followed through its wraps (``gateway.bus.counting``), so a
    #: counter that wrapped below 0 in EP0 is the negative position it is
    position: int | None = None
    counter: int | None = None  # the raw 24-bit counter of the last reading (0..16,777,215)
    #: the position was read since the controller's last reset or the line's reconnect
    position_current: bool = False
    moving: bool | None = None  # None: not read yet, or the moving motor is not known
    origin: Origin = Origin.UNKNOWN
    origin_cause: str | None = None  # why the origin was last lost (a reset the gateway saw)
    homing: bool = False  # an origin search was accepted and has not ended yet
    #: the counter may have changed since the last reading: motion, a preset, a search
    counting: bool = False
    #: the last reading was 0 by itself, from this position: a reset if the next says 0 too
    #: (one reading could be a reply bent on the line)
    zero_from: int | None = None
    sensors: SensorBits | None = None
    selected: bool = False  # F selects this motor (§10 F)
    step_out: bool = False  # 9 bit 6: held by the device until homing or RD (§10 9 ⑤)
    limit_error: bool = False  # latched, until acknowledged
    emergency: bool = False  # latched
    command_error: bool = False  # latched
    updated: float | None = None  # last fresh status or position
    stale: bool = True  # no fresh data for ``StateCache.stale_after`` seconds

    @property
    def homed(self) -> bool:
        """The origin is known: an origin search ended and no reset was seen since."""
        return self.origin is Origin.HOMED


@dataclass(frozen=True)
class ControllerState:
    """One controller: identity, framing, raw flags, latched errors and its two axes."""

    body: str
    online: bool | None = None  # None: not probed yet
    version: Version | None = None
    mode: int | None = None  # E (§10 E), also 9 bits 5,4
    #: the framing the line uses (§10 EE, EL, ER, SUM): the scheduler's word, set through the
    #: gateway or read back since the link came up; None while not known (the line assumes
    #: the loop's initial framing). Only the scheduler's ``FramingChanged`` writes it.
    framing: Framing | None = None
    status: StatusFlags | None = None  # the last "" reply as read
    condition: ConditionFlags | None = None  # the last 9 (form I) reply as read
    condition_bits: Mapping[int, int] = field(default_factory=lambda: MappingProxyType({}))
    program: ProgramState | None = None
    moving: bool | None = None  # "" bit 0; None: not read yet
    #: when the gateway last saw the controller reset (``gateway.bus.origin``)
    reset_at: float | None = None
    reset_cause: str | None = None  # why the gateway concluded the last reset
    selected_motor: int | None = None
    #: False while the selection is only inferred from a '>' (which does not mean the command
    #: was valid, §9-2) or in doubt; True once read back with 9, 97 or F, or taken on ER1's
    #: word (the scheduler's ``SelectionChanged``). The scheduler trusts only a confirmed one.
    selection_confirmed: bool = False
    last_moved: int | None = None  # the motor of the latest move the gateway knows of
    #: position management: True signed (EP1), False unsigned (EP0), None not read since the
    #: link came up or the controller came back (§10 EP; mode 1 is signed whatever EP says)
    signed_positions: bool | None = None
    latched: Mapping[ErrorKind, Latch] = field(default_factory=lambda: MappingProxyType({}))
    updated: float | None = None


@dataclass(frozen=True)
class LoopState:
    """One serial loop: link state, queue depth and the scheduler's counters."""

    name: str
    up: bool = False
    cause: str | None = None  # why it went down
    queue_depth: int = 0
    counters: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    updated: float | None = None


@dataclass(frozen=True)
class Change:
    """What changed in one loop, controller or axis: the new values of the fields that moved."""

    seq: int
    time: float
    loop: str
    body: str | None  # None: the loop itself
    motor: int | None  # None: the controller (or the loop)
    values: Mapping[str, Any]


@dataclass(frozen=True)
class Snapshot:
    """Everything at once, as of change ``seq``."""

    seq: int
    loops: Mapping[str, LoopState]
    controllers: Mapping[tuple[str, str], ControllerState]
    axes: Mapping[tuple[str, str, int], AxisState]
