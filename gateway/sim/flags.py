"""The latched error flags of one RC-233: two separate stores with their own clear-on-read.

``""`` reports the status flags and clears bits 1-3 after the reply; ``9`` (form I) reports the
condition flags and clears bits 0-3; neither read touches the other store (§10 "" 注意点,
§10 9 ④). Step-out (bit 6 of ``9``) is cleared by neither: only a completed homing search,
``RD`` in mode 1 or ``/EC`` clears it (§10 9 ⑤). ``K`` forms I, II and IV clear the limit and
EMS bits of the status flags (§10 K).

The ``K`` error output reacts to changes, not to levels (§10 K 解説): the limit bit of the
status flags going 0 -> 1 while the step-out bit is 0, the EMS bit going 0 -> 1, the step-out
bit going 0 -> 1. ``Flags`` notes those rises as they happen (``take_rises``), so that an error
a host read cleared meanwhile still counts once.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntFlag

from gateway.protocol.reply_values import ErrorWatch

__all__ = ["Error", "Flags"]


class Error(IntFlag):
    """The latched errors, numbered as their bit in both replies."""

    NONE = 0
    COMMUNICATION = 1  # bit 0 of 9 only: noise or receive overflow
    LIMIT = 2
    EMERGENCY = 4
    COMMAND = 8


#: The status flags (``""``) have no communication-error bit.
_STATUS_BITS = Error.LIMIT | Error.EMERGENCY | Error.COMMAND


@dataclass
class Flags:
    """Status and condition stores, the step-out latch, and the rises ``K`` reacts to."""

    status: Error = Error.NONE
    condition: Error = Error.NONE
    _step_out: bool = False
    _rises: ErrorWatch = ErrorWatch.NONE

    @property
    def step_out(self) -> bool:
        """Bit 6 of ``9``: a step-out was detected (§10 9, §10 Q)."""
        return self._step_out

    @step_out.setter
    def step_out(self, value: bool) -> None:
        if value and not self._step_out:
            self._rises |= ErrorWatch.STEP_OUT  # §10 K: the step-out bit went 0 -> 1
        self._step_out = value

    def raise_(self, error: Error) -> None:
        """Latch ``error`` in both stores (communication errors only in the condition flags)."""
        new = error & _STATUS_BITS & ~self.status
        # §10 K 解説: a limit rise counts for K only while the step-out bit is 0.
        if Error.LIMIT in new and not self._step_out:
            self._rises |= ErrorWatch.LIMIT
        if Error.EMERGENCY in new:
            self._rises |= ErrorWatch.EMERGENCY_STOP
        self.status |= error & _STATUS_BITS
        self.condition |= error

    def take_rises(self) -> ErrorWatch:
        """The errors that went 0 -> 1 since the last call (for the ``K`` error output)."""
        rises, self._rises = self._rises, ErrorWatch.NONE
        return rises

    def read_status(self) -> Error:
        """What ``""`` reports; the read clears the store (§10 "")."""
        value, self.status = self.status, Error.NONE
        return value

    def read_condition(self) -> Error:
        """What ``9`` form I reports; the read clears bits 0-3 (§10 9 ③)."""
        value, self.condition = self.condition, Error.NONE
        return value

    def clear_status(self, errors: Error) -> None:
        """Clear some status bits without a read (``K`` forms I, II, IV: limit and EMS)."""
        self.status &= ~errors
