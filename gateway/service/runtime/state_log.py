"""One log line per state change: loops up again, controllers offline and online, line faults
summarised. Never a line per poll.

``StateLog(gateway).start()`` subscribes to what the gateway already publishes (each loop
scheduler's events and the state cache's changes) and writes to the ``gateway.state`` logger,
every record carrying its context as ``extra`` (``event``, ``loop``, ``controller``) for the
JSON log format. The lines and their levels (docs/operations.md, "Log lines"):

* ``loop_up`` INFO: ``loop main up`` / ``loop main up again after 12.3 s down (cause)``;
  ``loop down`` itself is the scheduler's WARNING line ``loop main down: <cause>``;
* ``controller_offline`` WARNING: the controller stopped answering the poller;
* ``controller_online`` INFO: it answered for the first time, or again after being offline;
* ``line_faults`` WARNING: at most one line per loop per ``summary_period`` seconds, with the
  retries, '?' replies, time-outs, garbled and late replies counted since the last one, and
  only when there were some.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import BusEvent, LinkDown, LinkUp, TransactionDone, TransactionsTallied
from gateway.bus.state_types import Change
from gateway.service.runtime.runtime import Runtime

__all__ = ["FAULT_COUNTERS", "StateLog"]

log = logging.getLogger("gateway.state")

#: The counters a line-fault summary reports, with the words it uses.
FAULT_COUNTERS: dict[str, str] = {
    "retries": "retries",
    "naks": "'?' replies",
    "timeouts": "time-outs",
    "garbled": "garbled replies",
    "checksum_errors": "checksum errors",
    "late_replies": "late replies",
    "verifications": "read-backs after a lost reply",
}


@dataclass
class _LoopLog:
    down_since: float | None = None
    cause: str = ""
    seen_up: bool = False
    summarised: CountersSnapshot | None = None  # the counters at the last summary
    summarised_at: float = 0.0


@dataclass
class StateLog:
    """Writes the state-change lines of ``gateway`` (see the module)."""

    runtime: Runtime
    summary_period: float = 60.0
    clock: Callable[[], float] = time.monotonic
    _loops: dict[str, _LoopLog] = field(default_factory=dict)
    _online: dict[tuple[str, str], bool] = field(default_factory=dict)
    _stops: list[Callable[[], None]] = field(default_factory=list)

    def start(self) -> None:
        """Subscribe (before ``gateway.start()``, so the first ``loop up`` is seen)."""
        for name, scheduler in self.runtime.schedulers.items():
            self._loops[name] = _LoopLog(summarised_at=self.clock())
            self._stops.append(scheduler.events.subscribe(self._on_bus))
        self._stops.append(self.runtime.state.changes.subscribe(self._on_change))

    def stop(self) -> None:
        """Unsubscribe."""
        for stop in self._stops:
            stop()
        self._stops.clear()

    # ------------------------------------------------------------------ loops

    def _on_bus(self, event: BusEvent) -> None:
        loop = self._loops.setdefault(event.loop, _LoopLog(summarised_at=self.clock()))
        if isinstance(event, LinkDown):
            if loop.down_since is None:
                loop.down_since = self.clock()
            loop.cause = event.cause
        elif isinstance(event, LinkUp):
            extra = {"event": "loop_up", "loop": event.loop}
            if loop.down_since is not None and loop.seen_up:
                down = self.clock() - loop.down_since
                log.info(
                    "loop %s up again after %.1f s down (%s)", event.loop, down, loop.cause,
                    extra=extra | {"down_seconds": round(down, 3)},
                )  # fmt: skip
            else:
                log.info("loop %s up", event.loop, extra=extra)
            loop.seen_up = True
            loop.down_since = None
        elif isinstance(event, TransactionDone | TransactionsTallied):
            self._summarise(event.loop, loop, event.counters)

    def _summarise(self, name: str, loop: _LoopLog, counters: CountersSnapshot) -> None:
        now = self.clock()
        if loop.summarised is None:
            loop.summarised = CountersSnapshot()
        if now - loop.summarised_at < self.summary_period:
            return
        deltas = {
            key: getattr(counters, key) - getattr(loop.summarised, key) for key in FAULT_COUNTERS
        }
        loop.summarised, loop.summarised_at = counters, now
        faults = {key: n for key, n in deltas.items() if n > 0}
        if not faults:
            return
        words = ", ".join(f"{n} {FAULT_COUNTERS[key]}" for key, n in faults.items())
        log.warning(
            "loop %s: %s in the last %.0f s (of %d transactions in all)",
            name, words, self.summary_period, counters.transactions,
            extra={"event": "line_faults", "loop": name, "faults": faults},
        )  # fmt: skip

    # ------------------------------------------------------------------ controllers

    def _on_change(self, change: Change) -> None:
        if change.body is None or change.motor is not None or "online" not in change.values:
            return
        online = change.values["online"]
        if online is None:
            return
        key = (change.loop, change.body)
        before = self._online.get(key)
        self._online[key] = bool(online)
        if before is not None and before == bool(online):
            return
        controller = f"{change.loop}.{change.body}"
        extra = {"loop": change.loop, "controller": controller}
        if online:
            again = " again" if before is False else ""
            log.info(
                "controller %s online%s", controller, again,
                extra=extra | {"event": "controller_online"},
            )  # fmt: skip
        else:
            log.warning(
                "controller %s offline: it does not answer", controller,
                extra=extra | {"event": "controller_offline"},
            )  # fmt: skip
