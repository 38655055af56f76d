"""The counting rules of the 24-bit position counter, in one place (§7-4, §10 EP, §10 6).

The controller counts pulses in a 24-bit counter; EP0 reads it unsigned (0..16,777,215), EP1
and mode 1 signed (-8,388,608..+8,388,607): two views of the same bits. Moving CCW past 0 in
EP0 wraps the counter to 16,777,215 and below (§7-4: -2000 reads 16,775,216), so a reading
alone does not say whether 16,776,722 is a far position or -494.

The gateway follows the axis (docs/manual-notes.md "Wrapped counters"): the position is the
value of the counter's residue (mod 2^24) nearest to the previous position, as long as that
previous position is current (the axis was not stale, and no reset was seen since); else the
reading as the controller's format gives it. Between two readings of an axis less than 2^23
pulses pass (the poller reads a moving axis many times a second; the RC-233 pulses at most
at 240,000 pps, §7-1), so the nearest value is the one the axis went through.
"""

from __future__ import annotations

from gateway.protocol.params import (
    POSITION_MIN,
    SIGNED_MAX,
    UNSIGNED_MAX,
    PositionFormat,
)

__all__ = [
    "COUNTER_SPAN",
    "counter_of",
    "follow_counter",
    "target_range",
    "target_range_rule",
]

#: The counter's 2^24 values.
COUNTER_SPAN = UNSIGNED_MAX + 1


def counter_of(value: int) -> int:
    """The raw counter (0..16,777,215) that reads ``value`` in either view."""
    return value % COUNTER_SPAN


def follow_counter(reported: int, previous: int | None) -> int:
    """The axis's position after a reading ``reported`` (either view of the counter): the
    value with the same counter nearest to ``previous``; ``reported`` itself when there is no
    current previous position."""
    if previous is None:
        return reported
    delta = (counter_of(reported) - counter_of(previous)) % COUNTER_SPAN
    if delta >= COUNTER_SPAN // 2:
        delta -= COUNTER_SPAN
    return previous + delta


def target_range(fmt: PositionFormat) -> tuple[int, int]:
    """The targets a move may have in the format ``fmt`` without the counter wrapping: every
    value the controller writes and reads in that format (EP0 0..16,777,215, EP1 and mode 1
    -8,388,608..+8,388,607)."""
    return (0, UNSIGNED_MAX) if fmt is PositionFormat.UNSIGNED else (POSITION_MIN, SIGNED_MAX)


def target_range_rule(fmt: PositionFormat) -> str:
    """The rule a target outside ``target_range(fmt)`` breaks."""
    low, high = target_range(fmt)
    name = "unsigned management (EP0)" if fmt is PositionFormat.UNSIGNED else "signed management"
    return (
        f"in {name} a target lies in {low}..{high} pulses; beyond it the 24-bit position "
        "counter would wrap (§7-4, §10 EP)"
    )
