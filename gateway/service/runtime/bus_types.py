"""The bus's words that the faces (api/, mqtt/) read, named here so that a face imports service/
only (an import-linter contract holds it): events, line and state types, and the errors a
request can meet on its way to the line. Nothing is wrapped: these are the bus's own classes.
"""

from __future__ import annotations

from gateway.bus.config import LoopConfig
from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import BusEvent, EventBus, TransactionDone, TransactionsTallied
from gateway.bus.requests import DeadlineExpired, LoopDown, TransactionError
from gateway.bus.scheduler import LinkState
from gateway.bus.state import StateCache
from gateway.bus.state_types import AxisState, Change, ErrorKind

__all__ = [
    "AxisState",
    "BusEvent",
    "Change",
    "CountersSnapshot",
    "DeadlineExpired",
    "ErrorKind",
    "EventBus",
    "LinkState",
    "LoopConfig",
    "LoopDown",
    "StateCache",
    "TransactionDone",
    "TransactionError",
    "TransactionsTallied",
]
