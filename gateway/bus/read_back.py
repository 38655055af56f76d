"""Read-backs after a lost reply: did the command take effect? (DESIGN invariant 6)

A motion or non-idempotent command whose reply was lost (time-out, garbled, bad checksum) is
never sent again blindly: a move would run twice, an increment count twice. The scheduler reads
the device instead and reports DONE, NOT_DONE or UNKNOWN with what it saw. This module holds the
decisions; the transaction runner makes the reads.

* Motion (§10 "", §10 6): the motor's position ``6{mt}`` is read right before every motion
  command; after a lost reply ``""`` (bit 0: moving) and ``6{mt}`` again. Moving -> DONE;
  moved from the pre-read -> DONE; not moving and unchanged -> NOT_DONE; a command error
  latched (bit 3), or a read that failed -> UNKNOWN.
  ``""`` clears the device's error bits: the reads are published like every reply, so the
  state cache latches them (DESIGN invariant 4).
* Increments and decrements of a setting (``OHI``/``OHD``/``OLI``/``OLD``/``OSI``/``OSD``,
  §10 OH, OL, OS) and the error-output setting ``K`` forms I and II (§10 K, not idempotent
  because they also clear status bits): the value is read before, and after a lost reply read
  again and compared with what the command gives.
* EEPROM writes (§10 AW, DW, IW, EE///): the ``$B#*`` that ends the write proves the command
  was taken; without it the outcome is UNKNOWN.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

from gateway.bus.requests import Outcome
from gateway.protocol import commands
from gateway.protocol.commands import SPEED_STEPS, SpeedName
from gateway.protocol.models import Command
from gateway.protocol.replies import ReplyValue
from gateway.protocol.reply_values import ErrorOutput, ErrorWatch, PortByte, StatusFlags
from gateway.protocol.spec import Effect
from gateway.protocol.speeds import OS_MAX, SPEED_DATA_MAX

__all__ = [
    "ValueCheck",
    "motion_outcome",
    "position_query",
    "status_query",
    "value_check",
    "value_outcome",
]

#: §10 OH, OL: speed data 1-16,383; §10 OS: acceleration data 1-32,767.
_RANGES: dict[SpeedName, tuple[int, int]] = {
    "OH": (1, SPEED_DATA_MAX),
    "OL": (1, SPEED_DATA_MAX),
    "OS": (1, OS_MAX),
}


@functools.cache  # command models are frozen: one model serves every read-back
def status_query() -> Command:
    """``""``: the status flags (bit 0 = moving; bits 1-3 cleared by this read, §10 "")."""
    return commands.status()


@functools.cache
def position_query(motor: int | None) -> Command:
    """``6{mt}`` for a known motor (keeps the selection, §10 F), else ``6`` (selected motor)."""
    return commands.position(motor)


def motion_outcome(status: StatusFlags | None, before: int | None, after: int | None) -> Outcome:
    """DONE / NOT_DONE / UNKNOWN from what the read-backs saw.

    A command error in the status means a command was refused since the last ``""`` read,
    maybe this one (a motion command while moving is refused with '>', §9-1 注意): then the
    motor moving or a changed position proves nothing, and the outcome is UNKNOWN.
    """
    if status is not None and status.command_error:
        return Outcome.UNKNOWN
    if status is not None and status.moving:
        return Outcome.DONE
    if before is not None and after is not None:
        if after != before:
            return Outcome.DONE
        if status is not None:
            return Outcome.NOT_DONE
    return Outcome.UNKNOWN


@dataclass(frozen=True)
class ValueCheck:
    """How to verify a non-idempotent setting: the query, and the value the command gives."""

    query: Command
    expected: Callable[[ReplyValue], ReplyValue]


def _step(mnemonic: SpeedName, sign: int, amount: int) -> Callable[[ReplyValue], ReplyValue]:
    lo, hi = _RANGES[mnemonic]

    def expected(before: ReplyValue) -> ReplyValue:
        if not isinstance(before, int):
            return before
        result = before + sign * amount
        # Out of range: a command error, the value stays (§10 OS 注意点; OH/OL the same,
        # docs/manual-notes.md "OHI/OHD/OLI/OLD that leave 1-16,383").
        return result if lo <= result <= hi else before

    return expected


def value_check(command: Command) -> ValueCheck | None:
    """The read-back of a non-idempotent setting, or None when none can tell."""
    form = command.form
    params = command.params()
    for mnemonic in _RANGES:
        if form in SPEED_STEPS[mnemonic]:
            up = "id" in params
            amount = int(params["id"] if up else params["dd"])
            return ValueCheck(commands.speed(mnemonic), _step(mnemonic, 1 if up else -1, amount))
    if form is commands.ERROR_OUTPUT_MASK:
        value = ErrorOutput(
            ErrorWatch(int(params["dt"])), PortByte(int(params["du"]) << 4 | int(params["dl"]))
        )
        return ValueCheck(commands.error_output(), lambda _before: value)
    if form is commands.ERROR_OUTPUT_BITS:
        value = ErrorOutput(ErrorWatch(int(params["dt"])), PortByte.of(int(params["bt"])))
        return ValueCheck(commands.error_output(), lambda _before: value)
    return None


def value_outcome(
    before: ReplyValue | None, after: ReplyValue | None, check: ValueCheck
) -> Outcome:
    """DONE when the value is what the command gives; NOT_DONE when it stayed; else UNKNOWN."""
    if after is None or before is None:
        return Outcome.UNKNOWN
    if after == check.expected(before):
        return Outcome.DONE
    if after == before:
        return Outcome.NOT_DONE
    return Outcome.UNKNOWN


def is_motion(command: Command) -> bool:
    """Whether ``command`` starts motor motion (§10: moves, homing, jogs, single steps)."""
    return command.form.effect is Effect.MOTION


def resendable(command: Command) -> bool:
    """Safe to send again after a lost or garbled reply: idempotent and starts no motion."""
    return command.form.idempotent and not is_motion(command)
