"""The counters of one loop, for the state cache, the metrics and the
line-efficiency benchmark.

``busy_time`` is the wire time of every frame sent and every byte received (10 bits a
character at the line's rate, §2 8N1): over elapsed time it is the fraction of time the line
carries frames.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Counters", "CountersSnapshot"]


@dataclass(frozen=True)
class CountersSnapshot:
    """The counters at one moment (immutable)."""

    transactions: int = 0
    exchanges: int = 0  # frames sent, including retries and the scheduler's own
    retries: int = 0  # frames sent again ('?' or a lost reply of an idempotent command)
    naks: int = 0  # '?' replies (§9-2)
    timeouts: int = 0
    garbled: int = 0
    checksum_errors: int = 0
    late_replies: int = 0  # replies (or bytes) that came after their time-out
    verifications: int = 0  # read-backs made after a lost reply
    unsolicited: int = 0
    stale_bytes: int = 0  # discarded before a send
    bytes_out: int = 0
    bytes_in: int = 0
    busy_time: float = 0.0  # device seconds of wire time, both directions
    coalesced: int = 0  # requests answered by another identical request's transaction
    expired: int = 0  # requests whose deadline passed before they could start
    link_downs: int = 0


@dataclass
class Counters:
    """Mutable counters; ``snapshot()`` for a copy to publish."""

    transactions: int = 0
    exchanges: int = 0
    retries: int = 0
    naks: int = 0
    timeouts: int = 0
    garbled: int = 0
    checksum_errors: int = 0
    late_replies: int = 0
    verifications: int = 0
    unsolicited: int = 0
    stale_bytes: int = 0
    bytes_out: int = 0
    bytes_in: int = 0
    busy_time: float = 0.0
    coalesced: int = 0
    expired: int = 0
    link_downs: int = 0

    def snapshot(self) -> CountersSnapshot:
        """An immutable copy (of plain numbers: no deep copy as ``asdict`` makes)."""
        return CountersSnapshot(**vars(self))
