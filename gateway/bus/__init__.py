"""The loop scheduler: one per serial loop.

``LoopScheduler`` owns a loop's port: a priority queue of transactions, one frame in flight,
reply time-outs from the baud rate, safe retries and read-backs, motor selection, framing,
unsolicited messages and link health. ``events`` tells subscribers what it saw.
"""

from gateway.bus.config import LoopConfig
from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import (
    BusEvent,
    ControllerAnswering,
    EventBus,
    FramingChanged,
    LinkDown,
    LinkUp,
    ReplyObserved,
    SelectionChanged,
    TransactionDone,
    TransactionsTallied,
    TransactionTally,
    UnsolicitedMessage,
)
from gateway.bus.requests import (
    BusError,
    CommandResult,
    DeadlineExpired,
    LoopDown,
    Outcome,
    Priority,
    ReplyKind,
    TransactionError,
    TransactionResult,
)
from gateway.bus.scheduler import LinkState, LoopScheduler
from gateway.bus.trace import FrameDirection, LineTrace, TraceRecord

__all__ = [
    "BusError",
    "BusEvent",
    "CommandResult",
    "ControllerAnswering",
    "CountersSnapshot",
    "DeadlineExpired",
    "EventBus",
    "FrameDirection",
    "FramingChanged",
    "LineTrace",
    "LinkDown",
    "LinkState",
    "LinkUp",
    "LoopConfig",
    "LoopDown",
    "LoopScheduler",
    "Outcome",
    "Priority",
    "ReplyKind",
    "ReplyObserved",
    "SelectionChanged",
    "TraceRecord",
    "TransactionDone",
    "TransactionError",
    "TransactionResult",
    "TransactionTally",
    "TransactionsTallied",
    "UnsolicitedMessage",
]
