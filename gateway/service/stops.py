"""Stop-all: every axis of a controller, or of every controller on a loop, stopped at once.

A stop is never refused to an operator: no lease, motion, mode or online check, and a loop
stop does not give up on the other controllers when one of them cannot be reached. One frame
per controller is enough: ``S``/``SS`` act on the selected motor, and only the selected motor
can move (``F`` is refused while a motor moves, §10 F, §2), so one stop ends whatever the
controller is doing with either motor.

The stops of a loop are submitted together at stop priority: the scheduler sends them one after
the other as soon as the transaction in flight ends (one command in flight per loop). Each
controller's outcome is reported on its own; a controller whose stop could not be sent (the
loop is down, the request expired) is reported ``not_done`` or ``unknown`` with the reason,
never left out.
"""

from __future__ import annotations

import asyncio
from typing import Protocol

from pydantic import BaseModel, Field

from gateway.bus.requests import BusError, LoopDown, Outcome
from gateway.protocol import commands as cmd
from gateway.service.operations.terms import StopMode
from gateway.service.operations.types import Operation
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import ControllerRef

__all__ = ["ControllerStop", "LoopStop", "StopAll"]

#: The stop command of each mode (§10 S: at once; §10 SS: down to Low speed, then stop).
STOP_COMMANDS = {StopMode.IMMEDIATE: cmd.stop(), StopMode.DECELERATE: cmd.slow_stop()}


class StopNotes(Protocol):
    """What a stop tells the operations: the active one of a controller ends there."""

    def note_stop(self, loop: str, body: str) -> Operation | None:
        """Mark the active operation of ``loop.body`` as stopped; it (or None)."""


class ControllerStop(BaseModel):
    """What the stop of one controller did (both of its axes)."""

    controller: str = Field(examples=["sim.1"])
    axes: list[str] = Field(description="the axes the stop covers (every motor of it)")
    command: str = Field(description="S or SS")
    outcome: Outcome
    frames: list[str] = Field(description="what went out (empty when nothing could be sent)")
    operation: str | None = Field(description="the operation the stop ended, if one was active")
    error: str | None = Field(None, description="why the stop was not sent or its end is unknown")


class LoopStop(BaseModel):
    """What the stop of a loop did: one entry per controller, in body order."""

    loop: str
    outcome: Outcome = Field(
        description="done when every controller's stop is done; unknown when one is unknown; "
        "else not_done"
    )
    stops: list[ControllerStop]


class StopAll:
    """Stops of whole controllers and loops of ``gateway``."""

    def __init__(self, runtime: Runtime, operations: StopNotes) -> None:
        self.runtime = runtime
        self.operations = operations

    async def controller(self, ident: str, mode: StopMode) -> ControllerStop:
        """Stop controller ``ident`` (id or name): both of its axes."""
        return await self._stop(self.runtime.topology.controller(ident), mode)

    async def loop(self, name: str, mode: StopMode) -> LoopStop:
        """Stop every controller of loop ``name``, all submitted at once."""
        ref = self.runtime.topology.loop(name)
        stops = await asyncio.gather(*(self._stop(ctl, mode) for ctl in ref.controllers))
        return LoopStop(loop=ref.name, outcome=_overall(stops), stops=list(stops))

    async def _stop(self, ref: ControllerRef, mode: StopMode) -> ControllerStop:
        command = STOP_COMMANDS[mode]
        op = self.operations.note_stop(ref.loop, ref.body)
        stop = ControllerStop(
            controller=ref.id,
            axes=[a.id for a in ref.axes],
            command=command.wire(),
            outcome=Outcome.NOT_DONE,
            frames=[],
            operation=op.id if op is not None else None,
        )
        try:
            result = await self.runtime.scheduler(ref.loop).stop(ref.body, command)
        except LoopDown as exc:
            outcome = Outcome.UNKNOWN if exc.in_flight else Outcome.NOT_DONE
            return stop.model_copy(update={"outcome": outcome, "error": str(exc)})
        except BusError as exc:
            # refused before queueing or expired in the queue: nothing was sent
            return stop.model_copy(update={"outcome": Outcome.NOT_DONE, "error": str(exc)})
        error = None if result.outcome is Outcome.DONE else _why(result.outcome)
        return stop.model_copy(
            update={
                "outcome": result.outcome,
                "frames": result.frames,
                "error": error,
            }
        )


def _why(outcome: Outcome) -> str:
    if outcome is Outcome.NOT_DONE:
        return "the controller refused the stop"
    return "the reply to the stop was lost and the read-back could not decide"


def _overall(stops: list[ControllerStop]) -> Outcome:
    if all(s.outcome is Outcome.DONE for s in stops):
        return Outcome.DONE
    if any(s.outcome is Outcome.UNKNOWN for s in stops):
        return Outcome.UNKNOWN
    return Outcome.NOT_DONE
