"""The cell in ``/metrics``: per-controller and per-axis series, build and process metrics.

From the one state cache (DESIGN invariant 11) and the topology: each axis's position in
pulses, moving, stale and each latched error; each controller's online state and latched
errors; the operations by controller, kind and final state (the service's operation events);
time-outs and retries by controller (the loop's counters moved by each transaction, which is
the only one on its line: invariant 1).

What the gateway does not know is not exported: an axis whose data is stale has no
``rc233_axis_position_pulses`` sample (Prometheus then shows no value rather than an old one)
and ``rc233_axis_stale`` says why; a controller not probed yet, or on a loop that is down,
has no ``rc233_controller_online`` sample (``rc233_loop_up`` says why).
"""

from __future__ import annotations

import os
import platform
import resource
import time
from collections.abc import Callable
from pathlib import Path

from gateway import __version__
from gateway.api.metrics.exposition import Exposition
from gateway.service.events import EventKind, ServiceEvent
from gateway.service.operations.types import FINAL
from gateway.service.runtime.bus_types import (
    BusEvent,
    ErrorKind,
    TransactionDone,
    TransactionsTallied,
)
from gateway.service.runtime.runtime import Runtime

__all__ = ["CellMetrics", "render_build_and_process"]

#: axis error metric label -> AxisState field
_AXIS_ERRORS = {
    "limit_error": "limit_error",
    "emergency_stop": "emergency",
    "command_error": "command_error",
    "step_out": "step_out",
}
_FINAL = {str(state) for state in FINAL}


class CellMetrics:
    """Watches a gateway's events for the counts; renders the per-resource series."""

    def __init__(self, runtime: Runtime) -> None:
        self.runtime = runtime
        #: (controller id, kind, final state) -> operations
        self.operations: dict[tuple[str, str, str], int] = {}
        #: (controller id, counter) -> count; counter: timeouts, retries
        self.by_controller: dict[tuple[str, str], int] = {}
        self._last: dict[str, tuple[int, int]] = {}
        self._unsubscribe: list[Callable[[], None]] = [runtime.events.subscribe(self._on_event)]
        for name, scheduler in runtime.schedulers.items():
            counters = runtime.loop_counters(name)
            self._last[name] = (counters.timeouts, counters.retries)
            self._unsubscribe.append(scheduler.events.subscribe(self._on_bus))

    def close(self) -> None:
        """Stop watching."""
        for unsubscribe in self._unsubscribe:
            unsubscribe()

    def _on_event(self, event: ServiceEvent) -> None:
        if event.kind is not EventKind.OPERATION:
            return
        state, kind, axis = (event.data.get(k) for k in ("state", "kind", "axis"))
        if state in _FINAL and isinstance(axis, str):
            controller = axis.rpartition(".")[0]
            key = (controller, str(kind), str(state))
            self.operations[key] = self.operations.get(key, 0) + 1

    def _on_bus(self, event: BusEvent) -> None:
        if isinstance(event, TransactionsTallied):  # a worker's idle polls, in bulk
            for tally in event.tallies:
                self._moved(f"{event.loop}.{tally.body}", tally.timeouts, tally.retries)
            self._last[event.loop] = (event.counters.timeouts, event.counters.retries)
            return
        if not isinstance(event, TransactionDone):
            return
        timeouts, retries = event.counters.timeouts, event.counters.retries
        last = self._last.get(event.loop, (timeouts, retries))
        self._last[event.loop] = (timeouts, retries)
        self._moved(f"{event.loop}.{event.body}", timeouts - last[0], retries - last[1])

    def _moved(self, controller: str, timeouts: int, retries: int) -> None:
        for counter, moved in (("timeouts", timeouts), ("retries", retries)):
            if moved > 0:
                key = (controller, counter)
                self.by_controller[key] = self.by_controller.get(key, 0) + moved

    def render(self, out: Exposition) -> None:
        """The per-controller and per-axis families."""
        runtime = self.runtime
        cache, topology = runtime.state, runtime.topology
        controllers = list(topology.controllers())
        out.family("rc233_controller_online", "gauge", "1 answering, 0 silent; absent: unknown.")
        for ref in controllers:
            online = cache.controller(ref.loop, ref.body).online
            if online is not None and cache.loop(ref.loop).up:
                out.sample("rc233_controller_online", _ctl(ref.id, ref.name), int(online))
        out.family(
            "rc233_controller_error_latched", "gauge", "1 while an error is latched (by kind)."
        )
        for ref in controllers:
            latched = cache.controller(ref.loop, ref.body).latched
            for error in ErrorKind:
                labels = {**_ctl(ref.id, ref.name), "kind": error.value}
                out.sample("rc233_controller_error_latched", labels, int(error in latched))
        out.family("rc233_controller_operations_total", "counter", "Operations ended, by state.")
        for (controller, op_kind, state), count in sorted(self.operations.items()):
            labels = {"controller": controller, "kind": op_kind, "state": state}
            out.sample("rc233_controller_operations_total", labels, count)
        for counter, text in (("timeouts", "Replies that did not come in time."),
                              ("retries", "Frames sent again.")):  # fmt: skip
            metric = f"rc233_controller_{counter}_total"
            out.family(metric, "counter", text + " By controller.")
            for ref in controllers:
                count = self.by_controller.get((ref.id, counter), 0)
                out.sample(metric, _ctl(ref.id, ref.name), count)
        self._render_axes(out)
        self._render_adapters(out)

    def _render_adapters(self, out: Exposition) -> None:
        """Each local adapter as found when its port was last opened: a loop on a network
        line, or not opened yet, has no sample (nothing is known)."""
        adapters = sorted(
            (
                (name, report)
                for name, scheduler in self.runtime.schedulers.items()
                if (report := scheduler.transport.adapter) is not None
            ),
            key=lambda item: item[0],
        )
        metric = "rc233_loop_adapter_latency_timer_seconds"
        out.family(metric, "gauge", "The USB adapter's latency timer (sysfs latency_timer).")
        for name, report in adapters:
            if report.latency_timer_ms is not None:
                out.sample(metric, {"loop": name}, report.latency_timer_ms / 1000)
        metric = "rc233_loop_adapter_slow"
        out.family(
            metric, "gauge", "1 when the adapter's latency timer is above 2 ms: slow exchanges."
        )
        for name, report in adapters:
            out.sample(metric, {"loop": name}, int(report.warning is not None))
        metric = "rc233_loop_adapter_low_latency"
        out.family(metric, "gauge", "1 when the driver took the tty's low-latency flag.")
        for name, report in adapters:
            out.sample(metric, {"loop": name}, int(report.low_latency))

    def _render_axes(self, out: Exposition) -> None:
        cache = self.runtime.state
        axes = [
            (ref, cache.axis(ref.loop, ref.body, ref.motor)) for ref in self.runtime.topology.axes()
        ]
        out.family("rc233_axis_info", "gauge", "1 per axis: its name, controller and user unit.")
        for ref, _ in axes:
            labels = {"axis": ref.id, "name": ref.name or "", "controller": ref.controller_id,
                      "unit": ref.unit, "units_per_pulse": repr(ref.units_per_pulse)}  # fmt: skip
            out.sample("rc233_axis_info", labels, 1)
        out.family(
            "rc233_axis_position_pulses",
            "gauge",
            "Position (the counter followed through its wraps); absent when stale.",
        )
        for ref, state in axes:
            if not state.stale and state.position is not None:
                out.sample("rc233_axis_position_pulses", {"axis": ref.id}, state.position)
        out.family("rc233_axis_moving", "gauge", "1 while the motor turns; absent when stale.")
        for ref, state in axes:
            if not state.stale and state.moving is not None:
                out.sample("rc233_axis_moving", {"axis": ref.id}, int(state.moving))
        out.family(
            "rc233_axis_homed", "gauge", "1 while the origin is known (homed, no reset since)."
        )
        for ref, state in axes:
            out.sample("rc233_axis_homed", {"axis": ref.id}, int(state.homed))
        out.family(
            "rc233_axis_counter", "gauge", "The raw 24-bit position counter; absent when stale."
        )
        for ref, state in axes:
            if not state.stale and state.counter is not None:
                out.sample("rc233_axis_counter", {"axis": ref.id}, state.counter)
        out.family("rc233_axis_stale", "gauge", "1 when no fresh reading came for a while.")
        for ref, state in axes:
            out.sample("rc233_axis_stale", {"axis": ref.id}, int(state.stale))
        out.family("rc233_axis_error_latched", "gauge", "1 while the axis shows the error.")
        for ref, state in axes:
            for label, attr in _AXIS_ERRORS.items():
                on = int(getattr(state, attr))
                out.sample("rc233_axis_error_latched", {"axis": ref.id, "kind": label}, on)


def _ctl(ident: str, name: str | None) -> dict[str, str]:
    return {"controller": ident, "name": name or ""}


_PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096
_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def _start_time() -> float:
    """The process's start, seconds since the epoch (from /proc; now where there is none)."""
    try:
        stat = Path("/proc/self/stat").read_text()
        ticks = int(stat.rpartition(")")[2].split()[19])
        boot = next(
            int(line.split()[1])
            for line in Path("/proc/stat").read_text().splitlines()
            if line.startswith("btime ")
        )
        return boot + ticks / _TICKS
    except (OSError, ValueError, StopIteration, IndexError):
        return time.time()


_STARTED = _start_time()


def render_build_and_process(out: Exposition) -> None:
    """``rc233_build_info`` and the standard ``process_*`` metrics (Linux /proc)."""
    out.family("rc233_build_info", "gauge", "1, labelled with the gateway's version.")
    labels = {"version": __version__, "python": platform.python_version()}
    out.sample("rc233_build_info", labels, 1)
    usage = resource.getrusage(resource.RUSAGE_SELF)
    out.family("process_cpu_seconds_total", "counter", "User and system CPU seconds.")
    out.sample("process_cpu_seconds_total", {}, usage.ru_utime + usage.ru_stime)
    out.family("process_start_time_seconds", "gauge", "Start of the process since the epoch.")
    out.sample("process_start_time_seconds", {}, _STARTED)
    try:  # /proc is memory, not disk: these reads do not block
        size, resident = (int(v) for v in Path("/proc/self/statm").read_text().split()[:2])
        fds = len(os.listdir("/proc/self/fd"))
    except OSError:
        return
    out.family("process_virtual_memory_bytes", "gauge", "Virtual memory size.")
    out.sample("process_virtual_memory_bytes", {}, size * _PAGE)
    out.family("process_resident_memory_bytes", "gauge", "Resident memory size.")
    out.sample("process_resident_memory_bytes", {}, resident * _PAGE)
    out.family("process_open_fds", "gauge", "Open file descriptors.")
    out.sample("process_open_fds", {}, fds)
    out.family("process_max_fds", "gauge", "Limit of open file descriptors.")
    out.sample("process_max_fds", {}, resource.getrlimit(resource.RLIMIT_NOFILE)[0])
