"""What the edge node publishes: the node's metrics and each controller's, read from the cache.

One Sparkplug device per configured controller (its name, or ``loop.body`` when it has none).
Every metric has a fixed alias, unique across the edge node (Sparkplug 3.0 §6.4.2), given
once from the configuration, so a host keeps its aliases across rebirths.

Node metrics: ``bdSeq``, ``Node Control/Rebirth``, ``Properties/Version`` and per loop
``Loops/<loop>/Up``, ``Cause``, ``Line Utilisation``, ``Queue Depth``, ``Transactions``,
``Retries``, ``Timeouts``, ``Busy Seconds`` (host seconds the line was held by transactions,
measured as ``rc233_loop_busy_seconds_total``); ``MQTT/Superseded``.

Device metrics: ``Online``, ``Mode``, ``Version``, ``Program``, ``Moving``,
``Errors/<kind>`` for the controller-only latches, and per axis (named as configured, else
``m1``/``m2``) ``Axis/<a>/Position`` (pulses), ``Position User`` (``engUnit`` property),
``Target``, ``Moving``, ``Stale``, ``Errors/<kind>``, ``Soft Min``, ``Soft Max``; with DCMD
enabled also ``Axis/<a>/Stop``, ``Axis/<a>/Errors/Ack`` and ``Command/Token``.

Quality (DESIGN invariant 11): what the gateway does not know is ``None`` here (``is_null`` on
the wire): a stale axis has no position, no moving flag; a controller not probed yet has no
mode or version. A controller on a loop that is down, or that does not answer, is not
described at all: the edge node sends its DDEATH.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass

from gateway import __version__
from gateway.mqtt.sparkplug import DataType, Metric, Value
from gateway.service.runtime.bus_types import AxisState, ErrorKind, StateCache
from gateway.service.topology import AxisRef, ControllerRef, Topology

__all__ = ["AXIS_ERROR_KINDS", "CONTROLLER_ERROR_KINDS", "MetricTable", "device_id", "millis"]

#: Latched kinds shown on an axis (``step_out`` is the device's own held bit, §10 9 ⑤).
AXIS_ERROR_KINDS = ("limit_error", "emergency_stop", "command_error", "step_out")
#: Latched kinds of the controller alone.
CONTROLLER_ERROR_KINDS = (ErrorKind.COMMUNICATION.value, ErrorKind.PROGRAM.value)
LOOP_COUNTERS = {"Transactions": "transactions", "Retries": "retries", "Timeouts": "timeouts"}

#: name -> (value, timestamp in ms)
Values = dict[str, tuple[Value, int]]


def millis(wall: float | None = None) -> int:
    """Sparkplug timestamps: ms since the epoch (now when ``wall`` is None)."""
    return int((time.time() if wall is None else wall) * 1000)


_OFFSET = time.time() - time.monotonic()


def _stamp(monotonic: float | None, now: int) -> int:
    """A scheduler (monotonic) time as Sparkplug ms; ``now`` when never set."""
    return now if monotonic is None else int((monotonic + _OFFSET) * 1000)


def device_id(ref: ControllerRef) -> str:
    """A controller's Sparkplug device id: its name, else ``loop.body``."""
    return ref.name or ref.id


def axis_label(ref: AxisRef) -> str:
    """An axis in metric names: its name, else ``m1``/``m2``."""
    return ref.name or f"m{ref.motor}"


@dataclass(frozen=True)
class _Spec:
    alias: int
    datatype: DataType
    properties: Mapping[str, str] | None = None


class MetricTable:
    """The metric definitions (names, aliases, types) and their current values."""

    def __init__(self, topology: Topology, cache: StateCache, *, commands: bool) -> None:
        self.topology, self.cache, self.commands = topology, cache, commands
        self._next = 0
        self.node: dict[str, _Spec] = {}
        self.devices: dict[str, dict[str, _Spec]] = {}
        self.controllers: dict[str, ControllerRef] = {}
        #: target pulses of each axis's latest operation (the edge node feeds it)
        self.targets: dict[str, int | None] = {}
        #: alias -> (device or None, name): how commands that name aliases are read
        self.names: dict[int, tuple[str | None, str]] = {}
        self._define()

    # ------------------------------------------------------------------ definitions

    def _add(self, table: dict[str, _Spec], device: str | None, name: str, kind: DataType,
             properties: Mapping[str, str] | None = None) -> None:  # fmt: skip
        self._next += 1
        table[name] = _Spec(self._next, kind, properties)
        self.names[self._next] = (device, name)

    def _define(self) -> None:
        node = self.node
        self._add(node, None, "bdSeq", DataType.UINT64)
        self._add(node, None, "Node Control/Rebirth", DataType.BOOLEAN)
        self._add(node, None, "Properties/Version", DataType.STRING)
        self._add(node, None, "MQTT/Superseded", DataType.UINT64)
        self._add(node, None, "MQTT/Dropped Payloads", DataType.UINT64)
        self._add(node, None, "MQTT/Takeovers", DataType.UINT64)
        for loop in self.topology.loops():
            base = f"Loops/{loop.name}/"
            self._add(node, None, base + "Up", DataType.BOOLEAN)
            self._add(node, None, base + "Cause", DataType.STRING)
            self._add(node, None, base + "Line Utilisation", DataType.DOUBLE)
            self._add(node, None, base + "Queue Depth", DataType.INT32)
            for label in LOOP_COUNTERS:
                self._add(node, None, base + label, DataType.UINT64)
            self._add(node, None, base + "Busy Seconds", DataType.DOUBLE)
        for ctl in self.topology.controllers():
            dev = device_id(ctl)
            self.controllers[dev] = ctl
            table: dict[str, _Spec] = {}
            for name, kind in (("Online", DataType.BOOLEAN), ("Mode", DataType.INT32),
                               ("Version", DataType.STRING), ("Program", DataType.STRING),
                               ("Moving", DataType.BOOLEAN)):  # fmt: skip
                self._add(table, dev, name, kind)
            for kind_name in CONTROLLER_ERROR_KINDS:
                self._add(table, dev, f"Errors/{kind_name}", DataType.BOOLEAN)
            for axis in ctl.axes:
                base = f"Axis/{axis_label(axis)}/"
                self._add(table, dev, base + "Position", DataType.INT64, {"engUnit": "pulse"})
                unit = {"engUnit": axis.unit}
                self._add(table, dev, base + "Position User", DataType.DOUBLE, unit)
                self._add(table, dev, base + "Target", DataType.INT64, {"engUnit": "pulse"})
                self._add(table, dev, base + "Moving", DataType.BOOLEAN)
                self._add(table, dev, base + "Stale", DataType.BOOLEAN)
                for kind_name in AXIS_ERROR_KINDS:
                    self._add(table, dev, base + f"Errors/{kind_name}", DataType.BOOLEAN)
                self._add(table, dev, base + "Soft Min", DataType.DOUBLE, unit)
                self._add(table, dev, base + "Soft Max", DataType.DOUBLE, unit)
                if self.commands:
                    self._add(table, dev, base + "Stop", DataType.BOOLEAN)
                    self._add(table, dev, base + "Errors/Ack", DataType.BOOLEAN)
            if self.commands:
                self._add(table, dev, "Command/Token", DataType.STRING)
            self.devices[dev] = table

    # ------------------------------------------------------------------ values

    def alive(self, device: str) -> bool:
        """True when the controller's loop is up and it has not stopped answering."""
        ctl = self.controllers[device]
        return (
            self.cache.loop(ctl.loop).up
            and self.cache.controller(ctl.loop, ctl.body).online is not False
        )

    def node_values(self, bd_seq: int, extra: Mapping[str, Value]) -> Values:
        """The node's metrics now (``extra``: what the edge node measures itself)."""
        now = millis()
        out: Values = {
            "bdSeq": (bd_seq, now),
            "Node Control/Rebirth": (False, now),
            "Properties/Version": (__version__, now),
        }
        for name, value in extra.items():
            out[name] = (value, now)
        for loop in self.topology.loops():
            state = self.cache.loop(loop.name)
            base = f"Loops/{loop.name}/"
            stamp = _stamp(state.updated, now)
            out[base + "Up"] = (state.up, stamp)
            out[base + "Cause"] = (state.cause, stamp)
            out[base + "Queue Depth"] = (state.queue_depth, stamp)
            for label, key in LOOP_COUNTERS.items():
                count = state.counters.get(key)
                out[base + label] = (None if count is None else int(count), stamp)
        return out

    def device_values(self, device: str) -> Values:
        """One controller's metrics now."""
        ref = self.controllers[device]
        ctl = self.cache.controller(ref.loop, ref.body)
        now = millis()
        stamp = _stamp(ctl.updated, now)
        latched = {kind.value for kind in ctl.latched}
        out: Values = {
            "Online": (ctl.online, stamp),
            "Mode": (ctl.mode, stamp),
            "Version": (ctl.version.version if ctl.version else None, stamp),
            "Program": (ctl.program.value if ctl.program else None, stamp),
            "Moving": (ctl.moving if ctl.online else None, stamp),
        }
        for kind_name in CONTROLLER_ERROR_KINDS:
            out[f"Errors/{kind_name}"] = (kind_name in latched, stamp)
        for axis in ref.axes:
            state = self.cache.axis(ref.loop, ref.body, axis.motor)
            out.update(self._axis_values(axis, state, now))
        if self.commands:
            out["Command/Token"] = (None, now)
        return out

    def _axis_values(self, ref: AxisRef, state: AxisState, now: int) -> Values:
        base = f"Axis/{axis_label(ref)}/"
        stamp = _stamp(state.updated, now)
        known = not state.stale
        position = state.position if known else None
        errors = (state.limit_error, state.emergency, state.command_error, state.step_out)
        out: Values = {
            base + "Position": (position, stamp),
            base + "Position User": (ref.to_user(position), stamp),
            base + "Target": (self.targets.get(ref.id), now),
            base + "Moving": (state.moving if known else None, stamp),
            base + "Stale": (state.stale, stamp),
            base + "Soft Min": (ref.soft_min, now),
            base + "Soft Max": (ref.soft_max, now),
        }
        for kind_name, on in zip(AXIS_ERROR_KINDS, errors, strict=True):
            out[base + f"Errors/{kind_name}"] = (on, stamp)
        if self.commands:
            out[base + "Stop"] = (False, now)
            out[base + "Errors/Ack"] = (False, now)
        return out

    def metrics(self, table: Mapping[str, _Spec], values: Values, names: list[str] | None = None
                ) -> list[Metric]:  # fmt: skip
        """``Metric``s of ``names`` (every metric of ``table`` when None) from ``values``."""
        out = []
        for name in names if names is not None else list(table):
            spec = table[name]
            value, stamp = values[name]
            out.append(Metric(name, spec.alias, spec.datatype, value, stamp, spec.properties))
        return out


def changed(last: Values, now: Values) -> list[str]:
    """The names whose value moved (timestamps alone do not count: report by exception)."""
    return [name for name, (value, _) in now.items() if name not in last or last[name][0] != value]
