"""The latched error flags of one RC-233: two separate stores with their own clear-on-read.

``""`` reports the status flags and clears bits 1-3 after the reply; ``9`` (form I) reports the
condition flags and clears bits 0-3; neither read touches the other store (§10 "" 注意点,
§10 9 ④). Step-out (bit 6 of ``9``) is cleared by neither: only a completed homing search,
``RD`` in mode 1 or ``/EC`` clears it (§10 9 ⑤). ``K`` forms I, II and IV clear the limit and
EMS bits of the status flags (§10 K).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntFlag

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
    """Status and condition stores, plus the step-out latch."""

    status: Error = Error.NONE
    condition: Error = Error.NONE
    step_out: bool = False

    def raise_(self, error: Error) -> None:
        """Latch ``error`` in both stores (communication errors only in the condition flags)."""
        self.status |= error & _STATUS_BITS
        self.condition |= error

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
