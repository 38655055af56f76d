"""Is it one controller or the line? What one loop's silences say.

A time-out alone names nobody: the controller may be off, or the cable cut (a half-open line
opens fine and carries nothing). The books here tell the two apart: the controllers that have
answered on this loop, those silent since the last byte heard, and those deaf on purpose
(``EE///`` erases in silence, §10 EE///). When every controller that ever answered is silent
and ``timeouts_to_down`` time-outs in a row brought no byte, the line is gone (``check``);
before that, another controller is read (``needs_probe``) so a cut line is down within a few
time-outs, not after the poller's backoff for offline controllers.

``LineExchange`` tells it what each frame heard; the loop's lifecycle asks it whom to probe
and, after a reopen, whom to wait for.
"""

from __future__ import annotations

from collections.abc import Callable

from gateway.bus.config import LoopConfig
from gateway.bus.link import Link, LinkLost

__all__ = ["LineHealth"]


class LineHealth:
    """Who answers, who is silent, who is deaf on one loop; whether the line is gone."""

    def __init__(self, config: LoopConfig, link: Link, clock: Callable[[], float]) -> None:
        self._config = config
        self._link = link
        self._clock = clock
        #: controllers that have answered on this loop (kept across reconnects: the line is
        #: only up again when one of them answers, ``LoopLifecycle._answered``)
        self._answering: set[str] = set()
        #: controllers that timed out in silence since the last byte heard: when it covers
        #: every answering controller, the line is gone, not one controller (``check``)
        self._silent: set[str] = set()
        #: controllers that are deaf until this host time (EE/// erases in silence, §10 EE///)
        self._deaf_until: dict[str, float] = {}

    def answering(self) -> list[str]:
        """The controllers that have answered on this loop, in order."""
        return sorted(self._answering)

    def heard(self, body: str) -> None:
        """A frame to ``body`` heard a byte: nobody is silent any more, ``body`` answers."""
        self._silent.clear()
        self._answering.add(body)

    def timed_out(self, body: str) -> None:
        """A frame to ``body`` heard nothing at all."""
        self._silent.add(body)

    def deaf(self, body: str, until: float | None) -> None:
        """``body`` ignores every frame until host time ``until`` (None: it hears again)."""
        if until is None:
            self._deaf_until.pop(body, None)
        else:
            self._deaf_until[body] = until

    def reopened(self) -> None:
        """The port was opened again: nobody has been silent or deaf on this line yet."""
        self._deaf_until.clear()
        self._silent.clear()

    def heard_again(self) -> None:
        """A controller answered after the line was down: the silences counted are over."""
        self._silent.clear()

    def needs_probe(self) -> str | None:
        """After a time-out in silence: a controller to read now (None: no need).

        First those that answer and have not been silent since: if one answers, one
        controller is silent, not the line. Then round the silent ones until
        ``timeouts_to_down``, so a cut line goes down within a few time-outs rather than
        after the poller's backoff for offline controllers.
        """
        silent = self._link.silent_timeouts
        if not silent or not self._answering:
            return None
        others = sorted(self._answering - self._silent)
        if others:
            return others[0]
        every = sorted(self._answering)
        return every[silent % len(every)]

    def check(self, body: str) -> None:
        """Too many time-outs in a row with no byte at all: the line is gone (half-open)."""
        if self._deaf_until.get(body, 0.0) > self._clock():
            self._link.silent_timeouts = 0  # a controller erasing its EEPROM is silent on purpose
            return
        limit = self._config.timeouts_to_down
        if self._link.silent_timeouts >= limit and self._answering <= self._silent:
            cause = f"every controller silent: {limit} time-outs in a row with no byte received"
            self._link.lose(cause)
            raise LinkLost(cause)
