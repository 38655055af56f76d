"""Operations on disk: the record of one, and the verdict on one the gateway lost to a crash.

``to_record`` / ``from_record`` turn an ``Operation`` into the JSON the state store keeps and
back; what was asked is kept as the operation's ``kind`` and the asked fields (``request``),
the shape every version of the gateway has written.

An operation that had not ended when the process died (queued, sent or moving) is judged
after the restart by ``read_back_after_restart``: the axis is read (status, then its motor's
position) once its loop is up and its motor stands still, and the position is put against
the operation's end and its start:

* at the end (the target, or the pre-read plus the step) -> ``done``;
* where it started (the pre-read) -> ``failed``, outcome ``not_done``;
* a limit error or emergency stop in the status -> ``failed`` with that error;
* anything else, or nothing to compare with (a relative move whose pre-read was not
  recorded), or no answer within ``RESTART_READ_BACK`` host seconds -> ``unknown`` with why.

A jog left in flight is a hold-to-run motion whose holder died with the process: it is first
stopped (``SS``, ``restart_stop``), then read back once its motor stands still:

* stopped, no error in the status -> ``failed``, kind ``restart``, outcome ``not_done`` (it was
  ended by the gateway, not by its holder), the position where it stood; a jog toward a soft
  limit (a move to it) found at that limit -> ``done``;
* a limit error or emergency stop in the status -> ``failed`` with that error (it ran into it);
* the stop not taken within ``RESTART_READ_BACK`` -> ``unknown``, saying it may still run.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from typing import Any

from pydantic import ValidationError

from gateway.protocol import commands as cmd
from gateway.protocol.reply_values import StatusFlags
from gateway.service.operations.asked import asked_of, asked_record
from gateway.service.operations.restart_stop import (
    AT_RESTART,
    HOLD_TO_RUN,
    Occasion,
    RestartStop,
    stop_left_running,
)
from gateway.service.operations.types import Operation, OperationError, OperationState
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import Topology

__all__ = ["RESTART_READ_BACK", "Verdict", "from_record", "read_back_after_restart", "to_record"]

log = logging.getLogger("gateway.service")

#: Host seconds the read-back after a restart keeps trying (loop down, axis still moving).
RESTART_READ_BACK = 120.0

Verdict = tuple[OperationState, OperationError | None, int | None]


def to_record(op: Operation) -> dict[str, Any]:
    """What the state store keeps of ``op`` (JSON-able)."""
    return {
        "id": op.id,
        "axis": op.axis.id,
        "kind": op.kind,
        "request": asked_record(op.asked),
        "motor": op.motor,
        "target": op.target,
        "holder": op.holder,
        "prefix": op.prefix,
        "state": op.state.value,
        "position": op.position,
        "error": None if op.error is None else op.error.model_dump(mode="json"),
        "frames": list(op.frames),
        "created": op.created,
        "sent": op.sent,
        "ended": op.ended,
        "updated": op.updated,
        "step": op.step,
        "position_before": op.position_before,
        "stop_requested": op.stop_requested,
    }


def from_record(record: dict[str, Any], topology: Topology) -> Operation | None:
    """The operation of ``record``; None when its axis is no longer configured."""
    try:
        axis = topology.axis(record["axis"])
    except Exception:
        log.warning(
            "operation %s: axis %s is not configured any more; its record is not loaded",
            record.get("id"), record.get("axis"),
        )  # fmt: skip
        return None
    try:
        asked = asked_of(record["kind"], record["request"])
    except ValidationError as exc:
        log.error(
            "operation %s: its request does not fit its kind %r (%s); its record is not loaded",
            record.get("id"), record.get("kind"), exc.errors(include_url=False),
        )  # fmt: skip
        return None
    error = record.get("error")
    op = Operation(
        id=record["id"],
        axis=axis,
        asked=asked,
        motor=record["motor"],
        target=record["target"],
        holder=record["holder"],
        commands=(),  # its transaction ended with the process that sent it
        prefix=record["prefix"],
        state=OperationState(record["state"]),
        position=record["position"],
        error=None if error is None else OperationError.model_validate(error),
        frames=list(record["frames"]),
        created=record["created"],
        sent=record["sent"],
        ended=record["ended"],
        updated=record["updated"],
        step=record["step"],
        position_before=record["position_before"],
        stop_requested=record["stop_requested"],
    )
    if op.final:
        op.finished.set()
    return op


async def read_back_after_restart(
    runtime: Runtime,
    op: Operation,
    on_stop: Callable[[RestartStop], object] | None = None,
    occasion: Occasion = AT_RESTART,
) -> Verdict:
    """The verdict on ``op``, which had not ended when the gateway stopped (see the module);
    a hold-to-run motion is stopped first, and ``on_stop`` told what the stop did.

    ``occasion`` ``AT_LINK_UP``: the same for a jog whose loop went down while it ran, now that
    the loop is up again (``line_stop``); its verdict names that, with the error kind
    ``loop_down``."""
    loop = asyncio.get_running_loop()
    give_up = loop.time() + RESTART_READ_BACK
    stop: RestartStop | None = None
    if op.kind in HOLD_TO_RUN:
        stop = await stop_left_running(runtime, op, give_up, occasion)
        if on_stop is not None:
            on_stop(stop)
        if not stop.sent:
            detail = (
                f"{occasion.context(op)}; its holder is "
                f"gone, and its stop ({stop.command}, §10 {stop.command}) did not take effect "
                f"({stop.outcome.value}: {stop.error}): the axis may still be moving"
            )
            error = OperationError.of(occasion.kind, "Outcome unknown", detail, "unknown")
            return OperationState.UNKNOWN, error, None
    pause = 0.1
    last = "the loop did not come up"
    while True:
        try:
            result = await runtime.scheduler(op.axis.loop).submit(
                op.axis.body, [cmd.status(), cmd.position(op.motor)]
            )
            flags, position = (r.value for r in result.results)
            if isinstance(flags, StatusFlags) and _pulses(position):
                assert isinstance(position, int)
                if stop is not None and not flags.moving:
                    return _judge_stopped(op, stop, flags, position)
                if stop is None and (not flags.moving or op.expected_end is None):
                    return _judge(op, flags, position)
                last = f"the motor was still turning at {position} pulses"
            else:
                last = f"no usable answer ({result.outcome.value})"
        except Exception as exc:  # the loop is down, the controller silent: try again
            last = str(exc) or type(exc).__name__
        if loop.time() >= give_up:
            detail = (
                f"{occasion.context(op)}, and its axis "
                f"could not be read back within {RESTART_READ_BACK:.0f} s: {last}"
            )
            error = OperationError.of(occasion.kind, "Outcome unknown", detail, "unknown")
            return OperationState.UNKNOWN, error, None
        await asyncio.sleep(pause)  # a back-off between attempts, not a synchronisation
        pause = min(pause * 2, 2.0)


def _pulses(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _judge(op: Operation, flags: StatusFlags, position: int) -> Verdict:
    expected, before = op.expected_end, op.position_before
    seen = (
        f"the gateway restarted while the {op.kind} was {op.state.value}; read back then: "
        f"{position} pulses"
    )
    if expected is None:  # a relative move whose pre-read was not recorded (jogs: stopped)
        why = "the position before it was not recorded"
        return (
            OperationState.UNKNOWN,
            _error("Outcome unknown", f"{seen}; {why}", "unknown"),
            position,
        )
    if position == expected:
        return OperationState.DONE, None, position
    if before is not None and position == before:
        detail = f"{seen}, where it started: not carried out"
        return OperationState.FAILED, _error("Not done", detail, "not_done"), position
    if flags.limit_error:
        detail = f'{seen}; a limit sensor or a step-out error stopped it (§10 "" bit 1)'
        return (
            OperationState.FAILED,
            OperationError.of("limit_error", "Limit error", detail),
            position,
        )
    if flags.emergency_stop:
        detail = f'{seen}; the EMS input stopped it (§10 "" bit 2)'
        return (
            OperationState.FAILED,
            OperationError.of("emergency_stop", "Emergency stop", detail),
            position,
        )
    start = "not recorded" if before is None else str(before)
    detail = f"{seen}: neither its end {expected} nor its start ({start})"
    return OperationState.UNKNOWN, _error("Outcome unknown", detail, "unknown"), position


def _judge_stopped(op: Operation, stop: RestartStop, flags: StatusFlags, position: int) -> Verdict:
    sent = " ".join(stop.frames) or stop.command
    occasion = stop.occasion
    seen = (
        f"{occasion.context(op)}; its holder was gone, "
        f"so the gateway stopped it ({sent}, §10 {stop.command}); read back then: {position} "
        "pulses"
    )
    if flags.limit_error:
        detail = f'{seen}; a limit sensor or a step-out error had stopped it (§10 "" bit 1)'
        error = OperationError.of("limit_error", "Limit error", detail)
        return OperationState.FAILED, error, position
    if flags.emergency_stop:
        detail = f'{seen}; the EMS input had stopped it (§10 "" bit 2)'
        error = OperationError.of("emergency_stop", "Emergency stop", detail)
        return OperationState.FAILED, error, position
    if op.target is not None and position == op.target:
        # A jog toward a soft limit is a move to it: it had arrived before the stop.
        return OperationState.DONE, None, position
    error = OperationError.of(occasion.kind, occasion.title, seen, "not_done")
    return OperationState.FAILED, error, position


def _error(title: str, detail: str, outcome: str) -> OperationError:
    return OperationError.of("restart", title, detail, outcome)
