"""Loops, controllers and axes as clients read them: the response models and their builders.

Built from the bus's ``StateCache`` records and the topology (names, user units). Positions
are given in pulses as the controller counts them and, where the axis has a unit, in user
units too. Errors shown are the latched ones (DESIGN invariant 4): they stay until a client
acknowledges them (``POST /axes/{id}/errors/ack``).
"""

from __future__ import annotations

import time
from typing import Literal

from pydantic import BaseModel, Field, TypeAdapter

from gateway.bus.counters import CountersSnapshot
from gateway.bus.state_types import (
    AxisState,
    ControllerState,
    ErrorKind,
    Latch,
    LoopState,
    Origin,
)
from gateway.service.control import ControlView
from gateway.service.topology import AxisRef, ControllerRef
from gateway.transport.usb_latency import LATENCY_TIMER_LIMIT_MS, AdapterReport

__all__ = [
    "AdapterView",
    "AxisErrors",
    "AxisView",
    "ControllerView",
    "LatchView",
    "LoopView",
    "Sensors",
    "adapter_view",
    "axis_units",
    "axis_view",
    "controller_view",
    "loop_view",
    "wall_time",
]

_OFFSET = time.time() - time.monotonic()


def wall_time(monotonic: float | None) -> float | None:
    """A scheduler (monotonic) time as seconds since the epoch."""
    return None if monotonic is None else round(monotonic + _OFFSET, 6)


class Sensors(BaseModel):
    """The sensor inputs of one motor as last read (§10 8)."""

    cw_limit: bool
    ccw_limit: bool
    org: bool
    emergency_stop: bool
    step_out_sensor: bool


class AxisErrors(BaseModel):
    """The latched errors an axis shows, until acknowledged."""

    limit: bool = Field(description='limit error ("" / 9 bit 1)')
    emergency: bool = Field(description='emergency stop ("" / 9 bit 2)')
    command: bool = Field(description='command error ("" / 9 bit 3)')
    step_out: bool = Field(description="step-out (9 bit 6): held until homing or RD")


class AxisView(BaseModel):
    """One motor as the gateway last saw it."""

    id: str = Field(examples=["main.1.1"])
    name: str | None
    loop: str
    controller: str = Field(description="the controller's id, loop.body")
    motor: Literal[1, 2]
    position: int | None = Field(
        description="pulses: the controller's counter followed through its wraps, so a "
        "counter that wrapped below 0 in unsigned management (EP0) is the negative position "
        "it is (§7-4); null until read"
    )
    counter: int | None = Field(
        description="the raw 24-bit position counter as last read (0..16777215; in EP0 the "
        "controller's own reading)"
    )
    position_user: float | None = Field(
        description="position in `unit`; null while the origin is lost (a controller reset: "
        "the counter no longer counts from the machine's origin)"
    )
    unit: str = Field(description="the axis's user unit (mm, deg ...; `pulse` when it has none)")
    units: dict[str, str] = Field(
        description="the unit of every position field of this view: position in pulse, "
        "position_user, soft_min and soft_max in `unit`",
        examples=[
            {
                "position": "pulse",
                "counter": "pulse",
                "position_user": "mm",
                "soft_min": "mm",
                "soft_max": "mm",
            }
        ],
    )
    moving: bool | None = Field(description="null: not read yet, or which motor moves is not known")
    homed: bool = Field(
        description="the origin is known: an origin search was seen to end and no controller "
        "reset since (at gateway start: false, the origin is unknown)"
    )
    origin: Literal["unknown", "homed", "lost"] = Field(
        description="unknown: no origin search seen since the gateway started; homed; lost: a "
        "controller reset was seen (moves in user units and on axes with soft limits are "
        "refused until homed)"
    )
    origin_cause: str | None = Field(
        None, description="while the origin is lost: why the gateway concluded a reset"
    )
    selected: bool = Field(description="F selects this motor (§10 F)")
    sensors: Sensors | None
    errors: AxisErrors
    soft_min: float | None = Field(description="soft limit in `unit` (configuration)")
    soft_max: float | None = Field(description="soft limit in `unit` (configuration)")
    stale: bool = Field(description="no fresh reading for a while (the controller may be off)")
    updated: float | None = Field(description="seconds since the epoch of the last reading")
    control: ControlView = Field(
        description="its controller's control state: local refuses motion and settings from "
        "the network (stops pass)"
    )


class LatchView(BaseModel):
    """One latched error of a controller."""

    kind: str
    axes: list[int]
    first: float | None
    last: float | None
    count: int
    source: str


class ControllerView(BaseModel):
    """One controller: identity, mode, program state, latched errors, its axes' ids."""

    id: str = Field(examples=["main.1"])
    name: str | None
    loop: str
    body: str
    series: str
    online: bool | None = Field(description="None: not probed yet")
    version: str | None
    mode: int | None = Field(description="0 pulse, 1 encoder, 2 servo (§10 E)")
    moving: bool | None = Field(description="null: not read yet")
    selected_motor: int | None
    program: str | None = Field(description="GSS: 1 running, 0 ended, P paused, E error")
    signed_positions: bool | None = Field(
        default=None,
        description="position management as last read or set (§10 EP): true signed (EP1), "
        "false unsigned (EP0: no position below 0); null not known yet. Mode 1 always "
        "counts signed whatever EP says",
    )
    communication_error: bool
    latched: list[LatchView]
    axes: list[str]
    updated: float | None
    control: ControlView = Field(
        description="local refuses motion and settings from the network (stops pass)"
    )


class AdapterView(BaseModel):
    """How promptly the loop's local serial adapter passes received bytes on (a device path
    only). A USB adapter that holds them (an FTDI chip's latency timer: 16 ms by default)
    slows every exchange without any error."""

    tty: str = Field(description="the kernel's name of the port (the path's links resolved)",
                     examples=["ttyUSB0"])  # fmt: skip
    low_latency: bool = Field(
        description="the driver took the low-latency flag (false on a pseudo-terminal and "
        "on drivers without it: no fault by itself)"
    )
    latency_timer_ms: int | None = Field(
        description="the adapter's latency timer (/sys/bus/usb-serial/devices/<tty>/"
        "latency_timer); null when the device has none",
        examples=[1],
    )
    warning: str | None = Field(
        description=f"set when the latency timer is above {LATENCY_TIMER_LIMIT_MS} ms: what "
        "it costs and how to set it to 1"
    )


class LoopView(BaseModel):
    """One serial loop."""

    name: str
    port: str
    baud: int
    up: bool
    cause: str | None = Field(description="why the loop is down")
    queue_depth: int
    controllers: list[str]
    counters: CountersSnapshot | None = Field(
        description="the scheduler's counters (integers, busy_time in seconds); null before "
        "the loop's first transaction"
    )
    adapter: AdapterView | None = Field(
        default=None,
        description="the local adapter, as found when the port was last opened; null for "
        "socket:// and rfc2217:// lines and before the first open",
    )


def axis_units(ref: AxisRef) -> dict[str, str]:
    """Which unit each position field of an axis's view is in (pulses or the user unit)."""
    return {
        "position": "pulse",
        "counter": "pulse",
        "position_user": ref.unit,
        "soft_min": ref.unit,
        "soft_max": ref.unit,
    }


def axis_view(ref: AxisRef, state: AxisState, control: ControlView) -> AxisView:
    """The view of one axis."""
    sensors = state.sensors
    return AxisView(
        id=ref.id,
        name=ref.name,
        loop=ref.loop,
        controller=ref.controller_id,
        motor=ref.motor,
        position=state.position,
        counter=state.counter,
        position_user=None if state.origin is Origin.LOST else ref.to_user(state.position),
        unit=ref.unit,
        units=axis_units(ref),
        moving=state.moving,
        homed=state.homed,
        origin=state.origin.value,
        origin_cause=state.origin_cause if state.origin is Origin.LOST else None,
        selected=state.selected,
        sensors=None
        if sensors is None
        else Sensors(
            cw_limit=sensors.cw_limit,
            ccw_limit=sensors.ccw_limit,
            org=sensors.org,
            emergency_stop=sensors.emergency_stop,
            step_out_sensor=sensors.step_out_sensor,
        ),
        errors=AxisErrors(
            limit=state.limit_error,
            emergency=state.emergency,
            command=state.command_error,
            step_out=state.step_out,
        ),
        soft_min=ref.soft_min,
        soft_max=ref.soft_max,
        stale=state.stale,
        updated=wall_time(state.updated),
        control=control,
    )


def _latch(latch: Latch) -> LatchView:
    return LatchView(
        kind=latch.kind.value,
        axes=sorted(latch.axes),
        first=wall_time(latch.first),
        last=wall_time(latch.last),
        count=latch.count,
        source=latch.source,
    )


def controller_view(
    ref: ControllerRef, state: ControllerState, control: ControlView
) -> ControllerView:
    """The view of one controller."""
    return ControllerView(
        id=ref.id,
        name=ref.name,
        loop=ref.loop,
        body=ref.body,
        series=ref.series.value,
        online=state.online,
        version=state.version.version if state.version else None,
        mode=state.mode,
        moving=state.moving,
        selected_motor=state.selected_motor,
        program=state.program.value if state.program else None,
        signed_positions=state.signed_positions,
        communication_error=ErrorKind.COMMUNICATION in state.latched,
        latched=[_latch(latch) for latch in state.latched.values()],
        axes=[a.id for a in ref.axes],
        updated=wall_time(state.updated),
        control=control,
    )


#: The cache keeps counters as a mapping; validated back into integers (busy_time a float).
_COUNTERS = TypeAdapter(CountersSnapshot)


def adapter_view(report: AdapterReport | None) -> AdapterView | None:
    """What the last open of a loop's device path found out about its adapter."""
    if report is None:
        return None
    return AdapterView(
        tty=report.tty,
        low_latency=report.low_latency,
        latency_timer_ms=report.latency_timer_ms,
        warning=report.warning,
    )


def loop_view(
    name: str,
    port: str,
    baud: int,
    bodies: list[str],
    state: LoopState,
    adapter: AdapterReport | None = None,
) -> LoopView:
    """The view of one loop."""
    return LoopView(
        name=name,
        port=port,
        baud=baud,
        up=state.up,
        cause=state.cause,
        queue_depth=state.queue_depth,
        controllers=[f"{name}.{b}" for b in bodies],
        counters=_COUNTERS.validate_python(dict(state.counters)) if state.counters else None,
        adapter=adapter_view(adapter),
    )
