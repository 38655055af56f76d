"""What happens besides state changes, for clients to watch: operations, device messages, links.

State changes are the state cache's (numbered there); these are the other things a dashboard
or a monitoring system wants to see as they happen. The WebSocket feed (``feed``) numbers both
in one stream. Publishing is synchronous and never waits on a listener.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType
from typing import Any

__all__ = ["EventKind", "ServiceEvent", "ServiceEvents"]

log = logging.getLogger("gateway.service")


class EventKind(StrEnum):
    """What a service event is about."""

    UNSOLICITED = "unsolicited"  # $B#* (EEPROM write done), $B#T (timer up) (§10 AW, T)
    PROGRAM_OUTPUT = "program_output"  # what a running user program sends (§11-3)
    OPERATION = "operation"  # an operation was queued, sent, moving, done, failed, unknown
    LINK = "link"  # a loop went down or came up
    ERROR = "error"  # an error latched or acknowledged


@dataclass(frozen=True)
class ServiceEvent:
    """One event: its kind, the resource it is about (``axis:main.1.1``...), when, what."""

    kind: EventKind
    topic: str
    time: float  # wall clock, seconds since the epoch
    data: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))


class ServiceEvents:
    """Synchronous publish/listen of ``ServiceEvent``s."""

    def __init__(self) -> None:
        self._listeners: list[Callable[[ServiceEvent], None]] = []

    def listen(self, callback: Callable[[ServiceEvent], None]) -> Callable[[], None]:
        """Call ``callback`` with every event; returns the unsubscribe."""
        self._listeners.append(callback)

        def unsubscribe() -> None:
            if callback in self._listeners:
                self._listeners.remove(callback)

        return unsubscribe

    def publish(self, event: ServiceEvent) -> None:
        """Hand ``event`` to every listener; one failing listener does not stop the others."""
        for callback in list(self._listeners):
            try:
                callback(event)
            except Exception:
                log.exception("event listener %r failed", callback)
