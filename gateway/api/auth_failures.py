"""Failed authentications: back-off per client address, and one record per address a while.

A wrong token costs its sender one line of text and cost the gateway a 401, an audit entry of
kilobytes and a log line; thousands a second could be tried. ``AuthFailures`` keeps, per
client address (at most ``CAPACITY`` addresses, the least recently seen forgotten first):

* **back-off**: ``FREE_FAILURES`` wrong tokens are free; each one after blocks the address for
  ``BACKOFF_BASE`` seconds doubled each time (1, 2, 4 ... at most ``BACKOFF_MAX``). While
  blocked, every request from it that needs a token is answered ``429`` with ``Retry-After``
  before its token is looked at (a guess that would have been right is not told apart). A
  missing token is no guess and counts for the record only; a request that authenticates
  clears the address's count, and so do ``FORGET_AFTER`` seconds without a failure. An
  address seen no more for ``FORGET_AFTER`` seconds, neither blocked nor with a record still
  to write, is forgotten altogether: the book holds the addresses of the last quarter of an
  hour, not every address that ever failed (at most ``CAPACITY`` whatever the rate).
* **one record**: the first failure of an address is written (audit entry and a WARNING line)
  at once; those after it are counted and written as one record with the count when
  ``RECORD_INTERVAL`` seconds have passed since, and so on: at most one record an interval,
  whatever the rate. The records are kept in the audit as ``event: authentication_failed``
  with ``count`` (401s) and ``throttled`` (429s).
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from starlette.types import Scope

from gateway.api.problems import Problem, problem_type

__all__ = [
    "BACKOFF_BASE",
    "BACKOFF_MAX",
    "CAPACITY",
    "FREE_FAILURES",
    "RECORD_INTERVAL",
    "AuthFailures",
    "failures_of",
    "throttled_problem",
]

log = logging.getLogger("gateway.security")

#: wrong tokens an address may send before it is made to wait (a typo, a stale token)
FREE_FAILURES = 5
#: seconds of the first wait, doubled with every wrong token after it
BACKOFF_BASE = 1.0
#: the longest wait
BACKOFF_MAX = 300.0
#: seconds without a failure after which an address starts afresh
FORGET_AFTER = 900.0
#: seconds between two records of one address's failures
RECORD_INTERVAL = 60.0
#: addresses remembered (each a few hundred bytes)
CAPACITY = 4096


def _utc(seconds: float) -> str:
    moment = datetime.fromtimestamp(seconds, UTC)
    return moment.isoformat(timespec="milliseconds").replace("+00:00", "Z")


@dataclass
class _Address:
    """What is known of one client address's failures."""

    wrong: int = 0  #: wrong tokens since it last authenticated (or was forgotten)
    last_failure: float = 0.0
    blocked_until: float = 0.0
    #: failures (401) and refusals (429) not written yet, and since when
    pending: int = 0
    throttled: int = 0
    since: float = 0.0
    last_request: str = ""
    written_at: float = -math.inf
    timer: asyncio.TimerHandle | None = None
    seen: float = 0.0  #: the last failure or refusal (the book's clock)


class AuthFailures:
    """Back-off and aggregated records of failed authentications (see the module)."""

    def __init__(
        self,
        record: Callable[[dict[str, Any]], object],
        *,
        clock: Callable[[], float] = time.monotonic,
        wall: Callable[[], float] = time.time,
        capacity: int = CAPACITY,
        interval: float = RECORD_INTERVAL,
    ) -> None:
        self.record = record
        self.clock = clock
        self.wall = wall
        self.capacity = capacity
        self.interval = interval
        self._addresses: OrderedDict[str, _Address] = OrderedDict()

    def __len__(self) -> int:
        return len(self._addresses)

    def retry_after(self, address: str) -> float | None:
        """Seconds ``address`` must still wait (None: it may try)."""
        entry = self._addresses.get(address)
        if entry is None:
            return None
        wait = entry.blocked_until - self.clock()
        return wait if wait > 0 else None

    def throttled(self, address: str, request: str) -> None:
        """A request from ``address`` was refused 429 (it was blocked)."""
        entry = self._entry(address)
        entry.throttled += 1
        self._note(address, entry, request)

    def failed(self, address: str, request: str, *, guessed: bool) -> None:
        """A request from ``address`` was refused 401; ``guessed``: it gave a wrong token
        (False: none at all, which is counted in the record only)."""
        now = self.clock()
        entry = self._entry(address)
        if guessed:
            if now - entry.last_failure > FORGET_AFTER:
                entry.wrong = 0
            entry.wrong += 1
            entry.last_failure = now
            over = entry.wrong - FREE_FAILURES
            if over > 0:
                wait = min(BACKOFF_MAX, BACKOFF_BASE * 2 ** min(over - 1, 30))
                entry.blocked_until = now + wait
        entry.pending += 1
        self._note(address, entry, request)

    def succeeded(self, address: str) -> None:
        """A request from ``address`` authenticated: its wrong tokens are forgiven."""
        entry = self._addresses.get(address)
        if entry is not None and entry.wrong:
            entry.wrong = 0
            entry.blocked_until = 0.0

    def close(self) -> None:
        """Write every record still pending (at shutdown)."""
        for address, entry in list(self._addresses.items()):
            self._write(address, entry)

    def _entry(self, address: str) -> _Address:
        now = self.clock()
        self._forget_stale(now)
        entry = self._addresses.get(address)
        if entry is None:
            entry = self._addresses[address] = _Address()
            while len(self._addresses) > self.capacity:
                old, gone = self._addresses.popitem(last=False)
                self._write(old, gone)
        else:
            self._addresses.move_to_end(address)
        entry.seen = now
        return entry

    def _forget_stale(self, now: float) -> None:
        """Drop the least recently seen addresses that have nothing left to hold."""
        while self._addresses:
            address, entry = next(iter(self._addresses.items()))
            if (
                now - entry.seen <= FORGET_AFTER
                or entry.blocked_until > now
                or entry.pending
                or entry.throttled
            ):
                return
            del self._addresses[address]

    def _note(self, address: str, entry: _Address, request: str) -> None:
        if not entry.pending and not entry.throttled:
            return
        now = self.clock()
        if entry.pending + entry.throttled == 1:
            entry.since = self.wall()
        entry.last_request = request
        due = entry.written_at + self.interval
        if now >= due:
            self._write(address, entry)
        elif entry.timer is None:
            try:
                loop = asyncio.get_running_loop()
            except RuntimeError:  # no loop (a test, a thread): written with the next one
                return
            entry.timer = loop.call_later(due - now, self._write, address, entry)

    def _write(self, address: str, entry: _Address) -> None:
        if entry.timer is not None:
            entry.timer.cancel()
            entry.timer = None
        if not entry.pending and not entry.throttled:
            return
        count, throttled = entry.pending, entry.throttled
        entry.pending = entry.throttled = 0
        entry.written_at = self.clock()
        log.warning(
            "authentication failed %d time(s) from %s since %s (%d more refused 429 while "
            "it waited); last: %s",
            count, address, _utc(entry.since), throttled, entry.last_request,
        )  # fmt: skip
        entry_record: dict[str, Any] = {
            "time": _utc(self.wall()),
            "event": "authentication_failed",
            "token": None,
            "client": address,
            "method": entry.last_request.partition(" ")[0],
            "path": entry.last_request.partition(" ")[2],
            "status": 401 if count else 429,
            "count": count,
            "throttled": throttled,
            "since": _utc(entry.since),
        }
        try:
            self.record(entry_record)
        except Exception:  # the audit must never turn a refusal into an error
            log.exception("authentication failures not recorded: %r", entry_record)


def failures_of(scope: Scope) -> AuthFailures | None:
    """The failed-authentication book of the app serving ``scope`` (None: not kept)."""
    app = scope.get("app")
    failures = getattr(getattr(app, "state", None), "auth_failures", None)
    return failures if isinstance(failures, AuthFailures) else None


def throttled_problem(wait: float) -> Problem:
    """The 429 of an address that must wait ``wait`` seconds more."""
    return Problem(
        type=problem_type("too-many-failures"),
        title="Too many failed authentications",
        status=429,
        detail=f"too many wrong tokens from this address: try again in {math.ceil(wait)} s "
        "(the wait doubles with every wrong token after the first few)",
    )
