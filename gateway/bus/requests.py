"""What a caller hands the loop scheduler and what it gets back.

A request is one *transaction*: a sequence of commands to one controller that no other request
interleaves, except a stop: it goes before the transaction's next frame, and one to the same
controller ends what the transaction had still to do that acts. Its ``Priority`` decides its
place in the queue;
its result says, per command, what the controller answered and whether the command took effect
(``Outcome``): after a lost reply the scheduler reads the axis back instead of guessing
(DESIGN.md invariant 6), so a caller always learns ``DONE``, ``NOT_DONE`` or ``UNKNOWN``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import IntEnum, StrEnum
from types import MappingProxyType

from gateway.errors import GatewayError
from gateway.protocol.framing import CR, from_wire
from gateway.protocol.models import Command
from gateway.protocol.replies import ReplyValue

__all__ = [
    "BusError",
    "CommandResult",
    "DeadlineExpired",
    "LoopDown",
    "Outcome",
    "Priority",
    "ReplyKind",
    "TransactionError",
    "TransactionResult",
]


class Priority(IntEnum):
    """Queue order: lower goes first; FIFO within one priority."""

    STOP = 0  # S, SS, GES: the next frame out, even inside a transaction in flight
    OPERATOR = 1  # commands of people and integrations
    POLL = 2  # background polling


class Outcome(StrEnum):
    """Whether a command took effect on the device."""

    DONE = "done"  # answered normally, or the read-back shows it happened
    NOT_DONE = "not_done"  # refused ('?' after all retries, '>@'), or the read-back shows nothing
    UNKNOWN = "unknown"  # the reply was lost and the read-back could not decide


class ReplyKind(StrEnum):
    """What came back for a command (after any retries)."""

    ACCEPTED = "accepted"  # '>' (received; not "valid", §9-2)
    REJECTED = "rejected"  # '>@' (ER1: command error, §10 ER)
    DATA = "data"  # a query reply, decoded
    NOT_ACCEPTED = "not_accepted"  # '?' every time (§9-2: not taken)
    TIMEOUT = "timeout"  # nothing usable came back in time
    GARBLED = "garbled"  # bytes that fit no reply, or data that does not decode
    CHECKSUM = "checksum"  # SUM1 reply with a wrong checksum (§10 SUM)
    SKIPPED = "skipped"  # not sent: an earlier command of the transaction did not succeed


@dataclass(frozen=True)
class CommandResult:
    """The result of one command of a transaction.

    ``seen`` holds what read-backs showed (``status``, ``position_before``, ``position_after``,
    ``value_before``, ``value_after``, ``eeprom_done`` ...), so a caller can judge an UNKNOWN.
    """

    command: Command
    kind: ReplyKind
    outcome: Outcome
    value: ReplyValue | None = None
    attempts: int = 1
    late: bool = False  # the reply came after its time-out (and was still this command's)
    seen: Mapping[str, object] = field(default_factory=lambda: MappingProxyType({}))
    note: str = ""
    #: the command's frame as written to the line (its last attempt), CR and any SUM1
    #: checksum included; empty when it was never sent
    frame: bytes = b""

    @property
    def written(self) -> str:
        """``frame`` as text without its CR (``$1OH4000``; '' when never sent)."""
        return from_wire(self.frame.removesuffix(CR))


@dataclass(frozen=True)
class TransactionResult:
    """Every command's result, in order, and the outcome of the whole transaction.

    The transaction stops at the first command that is not DONE; the commands after it are
    reported SKIPPED / NOT_DONE and were never sent.
    """

    loop: str
    body: str
    results: tuple[CommandResult, ...]
    started: float  # scheduler clock (monotonic seconds)
    ended: float
    exchanges: int = 0  # frames sent, including the scheduler's own (F, read-backs, retries)

    @property
    def outcome(self) -> Outcome:
        """DONE when every command is DONE; otherwise the outcome of the first that is not."""
        for result in self.results:
            if result.outcome is not Outcome.DONE:
                return result.outcome
        return Outcome.DONE

    @property
    def ok(self) -> bool:
        """True when every command is DONE."""
        return self.outcome is Outcome.DONE

    @property
    def frames(self) -> list[str]:
        """The caller's commands as they were written (``$1OH4000``, with its checksum under
        SUM1; no CR), in order; the scheduler's own frames (``F``, read-backs) are not among
        them, nor a command never sent."""
        return [r.written for r in self.results if r.frame]

    @property
    def value(self) -> ReplyValue | None:
        """The value of the last command (the usual single query)."""
        return self.results[-1].value if self.results else None

    @property
    def values(self) -> tuple[ReplyValue | None, ...]:
        """The value of every command, in order."""
        return tuple(r.value for r in self.results)


class BusError(GatewayError):
    """Base of the loop scheduler's errors."""


class LoopDown(BusError):
    """The loop is down (port gone, or closed): the request was not carried out.

    ``retry_after`` is a hint in seconds (the next reconnect attempt). ``in_flight`` is True
    when the line went away during the transaction: commands already sent may have acted.
    """

    def __init__(
        self, loop: str, cause: str, *, retry_after: float | None = None, in_flight: bool = False
    ) -> None:
        hint = f"; retry in {retry_after:.1f} s" if retry_after is not None else ""
        what = (
            "went down during the transaction: the commands already sent may have acted"
            if in_flight
            else "is down"
        )
        super().__init__(f"loop {loop!r} {what} ({cause}){hint}")
        self.loop = loop
        self.cause = cause
        self.retry_after = retry_after
        self.in_flight = in_flight


class DeadlineExpired(BusError):
    """The request could not start before its deadline; nothing was sent."""

    def __init__(self, loop: str, body: str, waited: float, depth: int) -> None:
        super().__init__(
            f"loop {loop!r}: the request for controller {body} could not start within "
            f"{waited:.3f} s ({depth} requests queued); nothing was sent"
        )
        self.loop = loop
        self.body = body


class TransactionError(BusError):
    """A request the scheduler refuses before queueing it (no commands, bad body number...)."""
