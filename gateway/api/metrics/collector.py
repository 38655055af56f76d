"""Prometheus metrics, for those who run the cell: what ``GET /metrics`` exposes, in the text
exposition format 0.0.4, written here (no client library).

Per loop (label ``loop``): the scheduler's counters (``CountersSnapshot``), whether the line is
up, queue depth, transactions by outcome, the line's measured busy time and utilisation ratio
and a histogram of transaction durations (from its ``TransactionDone`` events, by priority).
Per controller and axis, ``rc233_build_info`` and ``process_*``: gateway/api/metrics/cell.py.
WebSocket clients and dropped clients (the hub reports into ``WsStats``). HTTP requests by
route template, method and status, and a duration histogram (``HttpMetricsMiddleware``).

Durations are host seconds (what a caller waits). ``rc233_loop_busy_seconds_total`` is their
sum, measured: the line is held from a transaction's first byte out to its last reply, so a
device server's extra latency (ser2net, an RFC 2217 box) shows in it and in
``rc233_loop_line_utilisation_ratio`` (busy over elapsed host seconds).
``rc233_loop_wire_seconds_total`` is the computed figure: the bytes at the baud rate.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from enum import Enum
from typing import Protocol

from fastapi import FastAPI
from starlette.types import ASGIApp, Receive, Scope, Send

from gateway.api.metrics.cell import CellMetrics, render_build_and_process
from gateway.api.metrics.exposition import Exposition, Histogram
from gateway.api.metrics.workers import render_workers
from gateway.api.middleware.access_log import log_access
from gateway.api.middleware.asgi_status import call_noting_status
from gateway.api.security import api_routes
from gateway.service.runtime.bus_types import (
    BusEvent,
    CountersSnapshot,
    EventBus,
    LinkState,
    LoopConfig,
    TransactionDone,
    TransactionsTallied,
)
from gateway.service.runtime.runtime import Runtime

__all__ = [
    "CONTENT_TYPE",
    "HTTP_BUCKETS",
    "KNOWN_METHODS",
    "OTHER_METHOD",
    "TRANSACTION_BUCKETS",
    "Histogram",
    "HttpMetrics",
    "HttpMetricsMiddleware",
    "LoopSource",
    "Metrics",
    "MetricsSource",
    "RouteTemplates",
    "WsStats",
    "method_label",
]

CONTENT_TYPE = "text/plain; version=0.0.4; charset=utf-8"
#: Transaction durations: one exchange at 9600 bps is ~5-30 ms (a few characters each way,
#: §2 10 bits a character, plus the controller's turnaround); a retry or read-back adds tens of
#: ms; an EEPROM write holds the line for seconds (§10 AW/DW/IW). 0.005 .. 5 s covers them.
TRANSACTION_BUCKETS = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0)
#: HTTP durations: cached reads take ~1 ms; ``?wait=true`` motion waits up to minutes.
HTTP_BUCKETS = (0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 60.0)
#: the route label of requests that matched no route (scanners must not explode the series)
UNMATCHED = "<unmatched>"
#: the methods HTTP defines (RFC 9110, PATCH RFC 5789): any other (WebDAV's PROPFIND, a
#: scanner's invention) is counted as ``OTHER_METHOD``, so methods cannot grow the series
KNOWN_METHODS = frozenset(
    {"GET", "HEAD", "POST", "PUT", "DELETE", "CONNECT", "OPTIONS", "TRACE", "PATCH"}
)
OTHER_METHOD = "other"


def method_label(method: str) -> str:
    """The ``method`` label of a request's method: itself when HTTP defines it, else other."""
    return method if method in KNOWN_METHODS else OTHER_METHOD


class LoopSource(Protocol):
    """What the metrics read of a loop scheduler (``gateway.bus.LoopScheduler``)."""

    @property
    def events(self) -> EventBus[BusEvent]:
        """The scheduler's events (``TransactionDone``)."""

    @property
    def config(self) -> LoopConfig:
        """Its settings (``time_scale``)."""

    @property
    def clock(self) -> Callable[[], float]:
        """Its clock (host seconds)."""

    @property
    def state(self) -> LinkState:
        """Where its line is."""

    @property
    def queue_depth(self) -> int:
        """Requests waiting to start."""


class MetricsSource(Protocol):
    """What the metrics and ``/readyz`` read of the gateway
    (``gateway.service.runtime.runtime.Runtime``)."""

    @property
    def schedulers(self) -> Mapping[str, LoopSource]:
        """The loop schedulers by loop name."""

    def ready(self) -> bool:
        """True when every loop is up."""

    def loop_counters(self, name: str) -> CountersSnapshot:
        """The counters of loop ``name`` now."""


@dataclass
class WsStats:
    """The WebSocket hub's counts: the hub calls ``connected``, ``disconnected``, ``dropped``."""

    clients: int = 0
    connections_total: int = 0
    dropped_by_reason: dict[str, int] = field(default_factory=dict)

    def connected(self) -> None:
        """A client completed its handshake."""
        self.clients += 1
        self.connections_total += 1

    def disconnected(self) -> None:
        """A client went away (for any reason, dropped ones too)."""
        self.clients = max(0, self.clients - 1)

    def dropped(self, reason: str = "backlog") -> None:
        """The server closed a client (``backlog``: it did not read; ``ping``: no pong)."""
        self.dropped_by_reason[reason] = self.dropped_by_reason.get(reason, 0) + 1


class HttpMetrics:
    """Requests by (route, method, status) and durations by (route, method)."""

    def __init__(self) -> None:
        self.requests: dict[tuple[str, str, str], int] = {}
        self.durations: dict[tuple[str, str], Histogram] = {}

    def observe(self, route: str, method: str, status: int, seconds: float) -> None:
        """Count one answered request."""
        key = (route, method, str(status))
        self.requests[key] = self.requests.get(key, 0) + 1
        hist = self.durations.get((route, method))
        if hist is None:
            hist = self.durations[(route, method)] = Histogram(HTTP_BUCKETS)
        hist.observe(seconds)


class RouteTemplates:
    """The route template (``/api/v1/axes/{ident}``) of a request that was routed.

    FastAPI >= 0.16x sets ``scope["route"]`` to the route as declared in its router, without
    the prefixes it was included with; the app's effective routes give the full template.
    """

    def __init__(self) -> None:
        self._by_route: dict[int, list[tuple[re.Pattern[str] | None, str]]] = {}

    def label(self, scope: Scope) -> str:
        """The template of the route that handled ``scope``, ``UNMATCHED`` when none did."""
        route = scope.get("route")
        if route is None:
            return UNMATCHED
        entries = self._by_route.get(id(route))
        if entries is None:
            self._index(scope.get("app"))
            entries = self._by_route.setdefault(id(route), [])
        if len(entries) == 1:
            return entries[0][1]
        path = scope.get("path", "")
        root = scope.get("root_path", "")
        if root and path.startswith(root):
            path = path[len(root) :]
        for regex, template in entries:  # one router included under several prefixes
            if regex is not None and regex.match(path):
                return template
        own = getattr(route, "path_format", None) or getattr(route, "path", None)
        return own if isinstance(own, str) and own else UNMATCHED

    def _index(self, app: object) -> None:
        if not isinstance(app, FastAPI):
            return
        self._by_route = {}
        for route in api_routes(app):
            self._by_route.setdefault(id(route.original), []).append((route.path_regex, route.path))


class HttpMetricsMiddleware:
    """Count every HTTP request by its route template (``/api/v1/axes/{id}``), and write its
    access line (``gateway.api.middleware.access_log``)."""

    def __init__(self, app: ASGIApp, metrics: Metrics) -> None:
        self.app = app
        self.http = metrics.http
        self.routes = RouteTemplates()

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """The ASGI entry point."""
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        began = time.perf_counter()

        def count(status: int | None) -> None:
            if status is not None:  # None: the client went away before any answer
                seconds = time.perf_counter() - began
                method = method_label(scope["method"])
                self.http.observe(self.routes.label(scope), method, status, seconds)
                log_access(scope, status)

        await call_noting_status(self.app, scope, receive, send, count)


#: CountersSnapshot field -> (metric name, help)
_COUNTERS: dict[str, tuple[str, str]] = {
    "exchanges": ("rc233_loop_exchanges_total", "Frames sent, retries and read-backs included."),
    "retries": ("rc233_loop_retries_total", "Frames sent again ('?' or a lost reply)."),
    "naks": ("rc233_loop_naks_total", "'?' replies (not taken, manual 9-2)."),
    "timeouts": ("rc233_loop_timeouts_total", "Replies that did not come in time."),
    "garbled": ("rc233_loop_garbled_total", "Replies that fit no reply form."),
    "checksum_errors": ("rc233_loop_checksum_errors_total", "SUM1 replies with a bad checksum."),
    "late_replies": ("rc233_loop_late_replies_total", "Replies that came after their time-out."),
    "verifications": ("rc233_loop_verifications_total", "Read-backs after a lost reply."),
    "unsolicited": ("rc233_loop_unsolicited_total", "Unsolicited messages ($B#*, $B#T, output)."),
    "stale_bytes": ("rc233_loop_stale_bytes_total", "Stray bytes discarded before a send."),
    "bytes_out": ("rc233_loop_bytes_sent_total", "Bytes written to the line."),
    "bytes_in": ("rc233_loop_bytes_received_total", "Bytes read from the line."),
    "busy_time": (
        "rc233_loop_wire_seconds_total",
        "Device seconds of wire time both ways, computed from the bytes at the baud rate.",
    ),
    "coalesced": ("rc233_loop_coalesced_total", "Requests answered by an identical one."),
    "expired": ("rc233_loop_expired_total", "Requests whose deadline passed before they began."),
    "link_downs": ("rc233_loop_link_downs_total", "Times the line went down."),
}
#: ``transactions`` is ``rc233_loop_transactions_total{outcome}``, counted from the events
_BY_OUTCOME = {"transactions"}
assert set(_COUNTERS) | _BY_OUTCOME == {f.name for f in fields(CountersSnapshot)}, (
    "a counter is not exported"
)


@dataclass
class _LoopWatch:
    started: float
    unsubscribe: Callable[[], None]
    #: host seconds the line was held by transactions, as measured (their durations)
    busy: float = 0.0
    durations: dict[str, Histogram] = field(default_factory=dict)
    outcomes: dict[str, int] = field(default_factory=dict)


def _count(watch: _LoopWatch, priority: Enum, outcome: str, duration: float) -> None:
    """One transaction ended: its duration by priority, the line's busy time, its outcome."""
    name = priority.name.lower()
    hist = watch.durations.get(name)
    if hist is None:
        hist = watch.durations[name] = Histogram(TRANSACTION_BUCKETS)
    hist.observe(duration)
    watch.busy += duration
    key = str(outcome)
    watch.outcomes[key] = watch.outcomes.get(key, 0) + 1


class Metrics:
    """Everything ``/metrics`` shows; ``attach()`` (again) after loops are added."""

    def __init__(self, runtime: MetricsSource | None = None, *, ws: WsStats | None = None):
        self.runtime = runtime
        self.ws = ws if ws is not None else WsStats()
        self.http = HttpMetrics()
        self._loops: dict[str, _LoopWatch] = {}
        #: the per-controller and per-axis series, for a real gateway (not a test's stand-in)
        self.cell = CellMetrics(runtime) if isinstance(runtime, Runtime) else None
        self.attach()

    def attach(self) -> None:
        """Watch the loops not watched yet (their transaction events, their busy time)."""
        if self.runtime is None:
            return
        for name, loop in self.runtime.schedulers.items():
            if name in self._loops:
                continue
            watch = _LoopWatch(loop.clock(), lambda: None)
            watch.unsubscribe = loop.events.subscribe(self._on_event_of(watch))
            self._loops[name] = watch

    def detach(self) -> None:
        """Stop watching every loop."""
        for watch in self._loops.values():
            watch.unsubscribe()
        self._loops.clear()
        if self.cell is not None:
            self.cell.close()

    @staticmethod
    def _on_event_of(watch: _LoopWatch) -> Callable[[BusEvent], None]:
        def on_event(event: BusEvent) -> None:
            if isinstance(event, TransactionDone):
                _count(watch, event.priority, event.outcome, event.duration)
            elif isinstance(event, TransactionsTallied):  # a worker's idle polls, in bulk
                for tally in event.tallies:
                    _count(watch, tally.priority, tally.outcome, tally.duration)

        return on_event

    def render(self) -> str:
        """The exposition text of every metric now."""
        self.attach()
        out = Exposition()
        render_build_and_process(out)
        self._render_loops(out)
        render_workers(out, self.runtime)
        if self.cell is not None:
            self.cell.render(out)
        self._render_ws(out)
        self._render_http(out)
        return out.text()

    def _render_loops(self, out: Exposition) -> None:
        runtime = self.runtime
        if runtime is None:
            return
        loops = sorted(runtime.schedulers.items())
        out.family("rc233_gateway_ready", "gauge", "1 when every loop is up.")
        out.sample("rc233_gateway_ready", {}, 1 if runtime.ready() else 0)
        snapshots = {name: runtime.loop_counters(name) for name, _ in loops}
        for attr, (metric, help_text) in _COUNTERS.items():
            out.family(metric, "counter", help_text)
            for name, _ in loops:
                out.sample(metric, {"loop": name}, getattr(snapshots[name], attr))
        out.family("rc233_loop_up", "gauge", "1 when the loop's line is up.")
        for name, loop in loops:
            out.sample("rc233_loop_up", {"loop": name}, 1 if loop.state is LinkState.UP else 0)
        out.family("rc233_loop_queue_depth", "gauge", "Requests waiting to start.")
        for name, loop in loops:
            out.sample("rc233_loop_queue_depth", {"loop": name}, loop.queue_depth)
        metric = "rc233_loop_busy_seconds_total"
        out.family(metric, "counter", "Host seconds the line was held by transactions (measured).")
        for name, _ in loops:
            out.sample(metric, {"loop": name}, self._loops[name].busy)
        out.family(
            "rc233_loop_line_utilisation_ratio",
            "gauge",
            "Measured busy seconds over elapsed seconds since the gateway began watching: "
            "a device server's latency shows here, not in the wire time.",
        )
        for name, loop in loops:
            watch = self._loops[name]
            elapsed = loop.clock() - watch.started
            ratio = min(1.0, watch.busy / elapsed) if elapsed > 0 else 0.0
            out.sample("rc233_loop_line_utilisation_ratio", {"loop": name}, ratio)
        out.family("rc233_loop_transactions_total", "counter", "Transactions by outcome.")
        for name, _ in loops:
            for outcome, count in sorted(self._loops[name].outcomes.items()):
                labels = {"loop": name, "outcome": outcome}
                out.sample("rc233_loop_transactions_total", labels, count)
        metric = "rc233_loop_transaction_duration_seconds"
        out.family(metric, "histogram", "Host seconds from a transaction's start to its end.")
        for name, _ in loops:
            for priority, hist in sorted(self._loops[name].durations.items()):
                out.histogram(metric, {"loop": name, "priority": priority}, hist)

    def _render_ws(self, out: Exposition) -> None:
        ws = self.ws
        out.family("rc233_ws_clients", "gauge", "WebSocket clients connected now.")
        out.sample("rc233_ws_clients", {}, ws.clients)
        out.family("rc233_ws_connections_total", "counter", "WebSocket clients ever connected.")
        out.sample("rc233_ws_connections_total", {}, ws.connections_total)
        out.family("rc233_ws_dropped_clients_total", "counter", "Clients the server closed.")
        for reason, count in sorted(ws.dropped_by_reason.items()):
            out.sample("rc233_ws_dropped_clients_total", {"reason": reason}, count)

    def _render_http(self, out: Exposition) -> None:
        out.family("rc233_http_requests_total", "counter", "HTTP requests answered.")
        for (route, method, status), count in sorted(self.http.requests.items()):
            labels = {"route": route, "method": method, "status": status}
            out.sample("rc233_http_requests_total", labels, count)
        metric = "rc233_http_request_duration_seconds"
        out.family(metric, "histogram", "Seconds from a request to the end of its handling.")
        for (route, method), hist in sorted(self.http.durations.items()):
            out.histogram(metric, {"route": route, "method": method}, hist)
