"""What a value's status code and a refused method's status code say, in OPC UA's words.

A value is never the last good number stamped ``Good``: ``Bad_NoCommunication`` while its loop
is down or its controller offline, ``Bad_WaitingForInitialData`` before the first reading,
``Uncertain_LastUsableValue`` when the reading is stale, ``Good`` only when fresh.

A refusal of the service layer maps to the status code a PLC's function block can branch on:
out of range or a soft limit ``Bad_OutOfRange``, a conflict or local control
``Bad_InvalidState``, the loop down or the device silent ``Bad_NoCommunication``.
"""

from __future__ import annotations

from asyncua import ua

from gateway.errors import (
    ConflictError,
    DeviceError,
    GatewayError,
    InvalidInputError,
    NotFoundError,
    StateUnavailable,
)
from gateway.service.runtime.bus_types import DeadlineExpired, LoopDown, TransactionError

__all__ = ["Freshness", "freshness", "refusal_status"]

Freshness = int  # a ua.StatusCodes value

GOOD: int = ua.StatusCodes.Good
STALE: int = ua.StatusCodes.UncertainLastUsableValue
NO_COMMUNICATION: int = ua.StatusCodes.BadNoCommunication
WAITING: int = ua.StatusCodes.BadWaitingForInitialData
OUT_OF_RANGE: int = ua.StatusCodes.BadOutOfRange
INVALID_STATE: int = ua.StatusCodes.BadInvalidState
NOT_FOUND: int = ua.StatusCodes.BadNotFound
INTERNAL: int = ua.StatusCodes.BadInternalError


def freshness(*, line_up: bool, online: bool | None, known: bool, stale: bool) -> Freshness:
    """The status of a value read from a controller: ``known`` a reading came at all."""
    if not line_up or online is False:
        return NO_COMMUNICATION
    if not known:
        return WAITING
    if stale:
        return STALE
    return GOOD


def refusal_status(exc: GatewayError) -> Freshness:
    """The status code a method answers ``exc`` with."""
    if isinstance(exc, LoopDown | DeadlineExpired | DeviceError | StateUnavailable):
        return NO_COMMUNICATION
    if isinstance(exc, ConflictError):
        return INVALID_STATE
    if isinstance(exc, NotFoundError):
        return NOT_FOUND
    if isinstance(exc, InvalidInputError | TransactionError):
        return OUT_OF_RANGE
    return INTERNAL
