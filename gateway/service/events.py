"""What happens besides state changes, for clients to watch: operations, device messages, links.

State changes are the state cache's (numbered there); these are the other things a dashboard
or a monitoring system wants to see as they happen. The WebSocket feed (``feed``) numbers both
in one stream. Publishing is synchronous and never waits on a subscriber.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType
from typing import Any

from gateway.bus.events import EventBus

__all__ = ["EventKind", "ServiceEvent", "ServiceEvents"]


class EventKind(StrEnum):
    """What a service event is about."""

    UNSOLICITED = "unsolicited"  # $B#* (EEPROM write done), $B#T (timer up) (§10 AW, T)
    PROGRAM_OUTPUT = "program_output"  # what a running user program sends (§11-3)
    OPERATION = "operation"  # an operation was queued, sent, moving, done, failed, unknown
    LINK = "link"  # a loop went down or came up
    ERROR = "error"  # an error latched or acknowledged
    CONTROL = "control"  # a controller went local or remote (or why it is local changed)
    ORIGIN = "origin"  # an axis's origin was lost (controller reset) or found (homed)


@dataclass(frozen=True)
class ServiceEvent:
    """One event: its kind, the resource it is about (``axis:main.1.1``...), when, what."""

    kind: EventKind
    topic: str
    time: float  # wall clock, seconds since the epoch
    data: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))


class ServiceEvents(EventBus[ServiceEvent]):
    """The service layer's events: the gateway's one ``EventBus``, carrying ``ServiceEvent``s
    (``subscribe``, ``publish``; a failing subscriber is logged and skipped)."""
