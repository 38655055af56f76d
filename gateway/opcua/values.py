"""What each variable of the address space shows: value, status code and source time.

Pure functions of the state cache (and the axes' targets): the face calls them for the
entities a change notification names and writes the variables whose triple moved. The source
time is the time of the reading the value comes from (the cache's ``updated``), as wall time.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from asyncua import ua

from gateway.opcua.status_codes import GOOD, WAITING, Freshness, freshness
from gateway.service.control import ControlState
from gateway.service.runtime.bus_types import AxisState, CountersSnapshot
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import AxisRef, ControllerRef
from gateway.service.views import wall_time

__all__ = [
    "AXIS_VARIABLES",
    "CONTROLLER_VARIABLES",
    "COUNTER_VARIABLES",
    "HAS_HOMED",
    "LOOP_VARIABLES",
    "Shown",
    "Target",
    "axis_values",
    "controller_values",
    "loop_values",
]

V = ua.VariantType

#: ``AxisState.origin`` after a controller reset (the bus's ``Origin.LOST``, a string enum).
ORIGIN_LOST = "lost"

#: Whether the state cache knows if an axis has found its origin (then ``Homed`` is shown;
#: ``AxisState.homed`` is a property of its ``origin``, not a field).
HAS_HOMED = hasattr(AxisState, "homed")

#: Per axis, after OPC 40010 ``AxisType.ParameterSet`` where it has a name for it.
AXIS_VARIABLES: dict[str, ua.VariantType] = {
    "ActualPosition": V.Double,
    "ActualPositionPulses": V.Int32,
    "TargetPosition": V.Double,
    "Moving": V.Boolean,
    **({"Homed": V.Boolean} if HAS_HOMED else {}),
    "LimitError": V.Boolean,
    "EmergencyError": V.Boolean,
    "CommandError": V.Boolean,
    "StepOutError": V.Boolean,
    "Stale": V.Boolean,
}
CONTROLLER_VARIABLES: dict[str, ua.VariantType] = {
    "Online": V.Boolean,
    "Mode": V.Int32,
    "SoftwareRevision": V.String,
    "ProgramState": V.String,
    "LocalControl": V.Boolean,
    "Moving": V.Boolean,
}
COUNTER_VARIABLES: dict[str, ua.VariantType] = {
    f.name: V.Double if f.type in (float, "float") else V.Int64
    for f in dataclasses.fields(CountersSnapshot)
}
LOOP_VARIABLES: dict[str, ua.VariantType] = {
    "LineUp": V.Boolean,
    "DownCause": V.String,
    "QueueDepth": V.Int32,
}


@dataclass(frozen=True)
class Shown:
    """One variable's value, status code and source time (seconds since the epoch)."""

    value: Any
    status: Freshness
    time: float | None

    def data_value(self, variant: ua.VariantType) -> ua.DataValue:
        """The DataValue to write; a Bad status carries no value (never a number to trust).

        A value that is not known is never Good nor Uncertain: asyncua refuses to write an
        empty variant to a typed variable unless the status is Bad, and the refusal would
        leave the variable showing its previous value as if it were current."""
        status = self.status
        if self.value is None and not ua.StatusCode(status).is_bad():
            status = WAITING
        bad = ua.StatusCode(status).is_bad()
        value = ua.Variant(None) if bad else ua.Variant(self.value, variant)
        stamp = None if self.time is None else datetime.fromtimestamp(self.time, UTC)
        return ua.DataValue(value, ua.StatusCode(status), SourceTimestamp=stamp)


@dataclass(frozen=True)
class Target:
    """The target of an axis's latest operation (pulses; None: it has none) and the time it
    was set (seconds since the epoch): ``TargetPosition``'s value and source time."""

    pulses: int | None
    time: float


def axis_values(runtime: Runtime, ref: AxisRef, target: Target | None) -> dict[str, Shown]:
    """Every variable of axis ``ref``; ``target`` its latest operation's target."""
    line = runtime.state.loop(ref.loop)
    ctl = runtime.state.controller(ref.loop, ref.body)
    state = runtime.state.axis(ref.loop, ref.body, ref.motor)
    when = wall_time(state.updated)

    def read(value: Any) -> Shown:
        known = value is not None and state.updated is not None
        return Shown(
            value,
            freshness(line_up=line.up, online=ctl.online, known=known, stale=state.stale),
            when,
        )

    pulses = read(state.position)
    # After a controller reset the counter no longer counts from the machine's origin: a
    # position in user units is not to be trusted until the axis is homed (as REST's
    # position_user is null); the pulses are still what the controller counts.
    lost = state.origin == ORIGIN_LOST
    user = Shown(None, WAITING, when) if lost else read(ref.to_user(state.position))
    shown = {
        "ActualPosition": user,
        "ActualPositionPulses": pulses,
        "TargetPosition": _target(ref, target),
        "Moving": read(state.moving),
        "LimitError": read(state.limit_error),
        "EmergencyError": read(state.emergency),
        "CommandError": read(state.command_error),
        "StepOutError": read(state.step_out),
        "Stale": Shown(state.stale, GOOD, when),
    }
    if HAS_HOMED:
        shown["Homed"] = read(state.homed)
    return shown


def _target(ref: AxisRef, target: Target | None) -> Shown:
    if target is None or target.pulses is None:
        return Shown(None, WAITING, None if target is None else target.time)
    return Shown(ref.to_user(target.pulses), GOOD, target.time)


def controller_values(
    runtime: Runtime, ref: ControllerRef, line_changed: float | None = None
) -> dict[str, Shown]:
    """Every variable of controller ``ref`` (its nameplate's revision too); ``line_changed``
    the time of its loop record's latest change (``loop_values``)."""
    line = runtime.state.loop(ref.loop)
    ctl = runtime.state.controller(ref.loop, ref.body)
    when = wall_time(ctl.updated)
    up = line.up

    def read(value: Any) -> Shown:
        return Shown(
            value,
            freshness(line_up=up, online=ctl.online, known=value is not None, stale=False),
            when,
        )

    online = Shown(ctl.online, WAITING if ctl.online is None else GOOD, when)
    if not up:
        # the line down: certainly not online, since the line went down
        online = Shown(False, GOOD, wall_time(line.updated or line_changed))
    local = runtime.control.view(ref).state is ControlState.LOCAL
    return {
        "Online": online,
        "Mode": read(ctl.mode),
        "SoftwareRevision": read(ctl.version.version if ctl.version else None),
        "ProgramState": read(ctl.program.value if ctl.program else None),
        "LocalControl": Shown(local, GOOD, when),
        "Moving": read(ctl.moving if ctl.online else None),
    }


def loop_values(runtime: Runtime, name: str, changed: float | None = None) -> dict[str, Shown]:
    """Every variable of loop ``name``: its line and its counters. ``changed``: the time of the
    loop record's latest change, the source time when the record has no ``updated`` of its
    own (the line's state and the counters are not readings of a controller)."""
    state = runtime.state.loop(name)
    when = wall_time(state.updated if state.updated is not None else changed)
    shown = {
        "LineUp": Shown(state.up, GOOD, when),
        "DownCause": Shown(state.cause or "", GOOD, when),
        "QueueDepth": Shown(state.queue_depth, GOOD, when),
    }
    for key, variant in COUNTER_VARIABLES.items():
        raw = state.counters.get(key)
        value = None if raw is None else (float(raw) if variant is V.Double else int(raw))
        shown[f"Counters/{key}"] = Shown(value, GOOD if raw is not None else WAITING, when)
    return shown
