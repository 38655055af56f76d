"""What a simulated controller puts on the line: the reply to a frame now, and the messages it
sends by itself later ($B#*, $B#T, a user program's output), each called off when it no longer
applies (a power cycle, a timer rewritten).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

__all__ = ["SILENT", "Later", "PowerOn", "Response"]


@dataclass(frozen=True)
class Later:
    """A message the controller sends by itself at simulated time ``at`` ($B#*, $B#T, ...).

    ``still`` (when given) is asked at that time: False means the message was called off
    (a timer rewritten by GWT or restarted, a power cycle).
    """

    at: float
    data: bytes
    still: Callable[[], bool] | None = None

    def wanted(self) -> bool:
        """True when the message is still to be sent."""
        return self.still is None or self.still()


@dataclass(frozen=True)
class Response:
    """What the controller puts on the line for one frame: now, and later."""

    reply: bytes
    later: tuple[Later, ...] = ()


SILENT = Response(b"")


@dataclass
class PowerOn:
    """One power-on of a controller: a power cycle starts a new one, and the messages queued
    in the old one are called off with it."""

    on: bool = True
    busy_until: float = float("-inf")  # EE/// erase in progress
    later: list[Later] = field(default_factory=list)
