"""How often one command may be sent again, in one place for every sender of the bus.

'?' means the controller did not take the frame (§9-2): it is sent again, up to
``LoopConfig.nak_retries`` times. A lost or garbled reply leaves doubt: the frame is sent
again only when that is safe (an idempotent form that starts no motion, ``verify.resendable``),
up to ``LoopConfig.resend_retries`` times; anything else is read back instead, never resent
blindly (DESIGN invariant 6). Every retry is counted in the loop's ``Counters.retries``.
"""

from __future__ import annotations

from dataclasses import dataclass

from gateway.bus.config import LoopConfig
from gateway.bus.counters import Counters
from gateway.bus.read_back import resendable
from gateway.protocol.models import Command

__all__ = ["Retries"]


@dataclass
class Retries:
    """The retries one command has had, and whether it may have another."""

    config: LoopConfig
    counters: Counters
    naks: int = 0
    resends: int = 0

    def after_nak(self) -> bool:
        """'?' came: whether to send the frame again (and count it)."""
        if self.naks >= self.config.nak_retries:
            return False
        self.naks += 1
        self.counters.retries += 1
        return True

    def after_doubt(self, command: Command) -> bool:
        """The reply was lost or garbled: whether ``command`` may simply be sent again."""
        if not resendable(command) or self.resends >= self.config.resend_retries:
            return False
        self.resends += 1
        self.counters.retries += 1
        return True
