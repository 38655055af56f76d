"""The records of an operation: its states, its error, the view clients read.

``Operation`` is the mutable record ``Operations`` keeps and updates as the motion goes on;
``OperationView`` is what the API answers and the events carry.
"""

from __future__ import annotations

import asyncio
import time
from dataclasses import dataclass, field
from enum import StrEnum

from pydantic import BaseModel, Field

from gateway.protocol.models import Command
from gateway.service.operations.asked import Asked, HomeAsked, JogAsked, MoveAsked, StepAsked
from gateway.service.topology import AxisRef

__all__ = [
    "FINAL",
    "Operation",
    "OperationError",
    "OperationState",
    "OperationView",
]


class OperationState(StrEnum):
    """Where an operation stands."""

    QUEUED = "queued"  # created, its transaction waits for the line
    SENT = "sent"  # the controller answered '>' (received, §9-2; not yet seen moving)
    MOVING = "moving"  # a status read saw the motor turn
    DONE = "done"  # ended without an error
    FAILED = "failed"  # refused, not carried out, or ended by an error or a stop
    UNKNOWN = "unknown"  # the outcome cannot be known (lost reply, loop or controller gone)


#: The states an operation never leaves.
FINAL = frozenset({OperationState.DONE, OperationState.FAILED, OperationState.UNKNOWN})


class OperationError(BaseModel):
    """Why an operation failed or is unknown, problem-like."""

    kind: str = Field(
        description="limit_error, emergency_stop, command_error, stopped, not_reached, device, "
        "loop_down, offline, refused, restart (judged after the gateway restarted)"
    )
    title: str
    detail: str
    outcome: str | None = Field(
        default=None, description="the scheduler's verdict on the command: not_done or unknown"
    )

    @classmethod
    def of(cls, kind: str, title: str, detail: str, outcome: str | None = None) -> OperationError:
        """An error from its parts."""
        return cls(kind=kind, title=title, detail=detail, outcome=outcome)


class OperationView(BaseModel):
    """One motion request and how it went."""

    id: str = Field(examples=["op-1-00012345"])
    axis: str = Field(description="the axis id, loop.body.motor")
    axis_name: str | None
    kind: str = Field(description="move, home, jog or step")
    # A plain union: the view is handed the operation's own model instance, which passes
    # as it is; the asked models leave ``kind`` out of their JSON (it is the field above).
    request: MoveAsked | HomeAsked | JogAsked | StepAsked = Field(
        description="the request as given (its shape follows `kind`)"
    )
    state: OperationState
    target: int | None = Field(description="the target position in pulses, when there is one")
    target_user: float | None = Field(description="the target in `unit`")
    position: int | None = Field(description="the final position in pulses, once ended")
    position_user: float | None = Field(description="the final position in `unit`")
    unit: str = Field(description="the axis's user unit (`pulse` when it has none)")
    units: dict[str, str] = Field(
        description="the unit of every position field: target and position in pulse, "
        "target_user and position_user in `unit`",
        examples=[
            {"target": "pulse", "target_user": "mm", "position": "pulse", "position_user": "mm"}
        ],
    )
    error: OperationError | None
    frames: list[str] = Field(description="the command frames sent (without the CR)")
    holder: str | None = Field(description="who asked (the token's name)")
    created: float = Field(description="seconds since the epoch")
    sent: float | None
    ended: float | None
    updated: float


@dataclass(eq=False)
class Operation:
    """One operation as ``Operations`` keeps it."""

    id: str
    axis: AxisRef
    asked: Asked  # what was asked; its ``kind`` is the operation's
    motor: int
    target: int | None
    holder: str | None
    commands: tuple[Command, ...]  # the transaction's commands, to recognise its TransactionDone
    prefix: str = "$"
    state: OperationState = OperationState.QUEUED
    position: int | None = None
    error: OperationError | None = None
    frames: list[str] = field(default_factory=list)
    created: float = field(default_factory=time.time)
    sent: float | None = None
    ended: float | None = None
    updated: float = field(default_factory=time.time)
    # tracking
    armed: bool = False  # the transaction is done: status reads from now on are the motion's
    stop_requested: bool = False
    errors: set[str] = field(default_factory=set)
    ending: asyncio.Future[int] | None = None
    finished: asyncio.Event = field(default_factory=asyncio.Event)
    #: relative moves and steps: the pulses moved by (the end is the pre-read plus this)
    step: int | None = None
    #: the position read right before the motion command was sent (the scheduler's pre-read)
    position_before: int | None = None
    rechecked: bool = False  # the end was read again once (a status reply may be bent)

    @property
    def expected_end(self) -> int | None:
        """Where the axis is once the motion is carried out: the pre-read plus the step of a
        relative move, the target of an absolute one (None: not known, a jog)."""
        if self.step is not None:
            return None if self.position_before is None else self.position_before + self.step
        return self.target

    @property
    def kind(self) -> str:
        """move, home, jog or step (the asked model's)."""
        return self.asked.kind

    @property
    def final(self) -> bool:
        """True once the operation has ended (done, failed or unknown)."""
        return self.state in FINAL

    def view(self) -> OperationView:
        """What clients see."""
        return OperationView(
            id=self.id,
            axis=self.axis.id,
            axis_name=self.axis.name,
            kind=self.kind,
            request=self.asked,
            state=self.state,
            target=self.target,
            target_user=self.axis.to_user(self.target),
            position=self.position,
            position_user=self.axis.to_user(self.position),
            unit=self.axis.unit,
            units={
                "target": "pulse",
                "target_user": self.axis.unit,
                "position": "pulse",
                "position_user": self.axis.unit,
            },
            error=self.error,
            frames=list(self.frames),
            holder=self.holder,
            created=round(self.created, 6),
            sent=None if self.sent is None else round(self.sent, 6),
            ended=None if self.ended is None else round(self.ended, 6),
            updated=round(self.updated, 6),
        )
