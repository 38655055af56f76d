"""Wire times and reply time-outs, from the baud rate and the frame lengths (DESIGN invariant 7).

A character is 10 bits on the line (start, 8 data, stop: §2 8N1), about 1.04 ms at 9600 bps
(§3-I: "about 1 ms a character"). The time-out of a reply is the wire time of the command plus
the longest reply its framing allows, plus a turnaround margin for the controller; never a
constant, so 300 bps gets 32 times the time 9600 does.

Everything here is in *device* seconds. ``Timing`` turns them into the host's real seconds:
divided by the time scale (1 on a real line; the simulator's speed-up in tests and the scaled
benchmark) plus the host's own latency (OS, USB-serial adapters, the event loop), which does
not scale.
"""

from __future__ import annotations

from dataclasses import dataclass

from gateway.protocol.framing import BITS_PER_CHAR, Framing
from gateway.protocol.models import Command
from gateway.protocol.program import CAPACITY_BYTES
from gateway.protocol.replies import REPLY_OVERHEAD, reply_length
from gateway.protocol.spec import ReplyFormat

__all__ = [
    "BITS_PER_CHAR",
    "CHECKSUM_CHARS",
    "LONGEST_FIXED_REPLY",
    "Timing",
    "ack_chars",
    "char_time",
    "data_chars",
    "reply_chars",
    "wire_time",
]

#: two hex digits before the CR of every CR-terminated message with SUM1 (§10 SUM)
CHECKSUM_CHARS = 2
#: the longest data reply: ``IR`` with a full program (§10 IR; capacity §1, §10 I)
_LONGEST_DATA = REPLY_OVERHEAD + CAPACITY_BYTES
#: The longest reply of fixed width any command gets (§15: ``V``'s version text). A program's
#: text (``IR``) is longer, but it is a stream of bytes: while it flows the line is not quiet.
LONGEST_FIXED_REPLY = max(
    length for fmt in ReplyFormat if fmt.has_data and (length := reply_length(fmt)) is not None
)


def char_time(baud: int) -> float:
    """Seconds one character takes on the line at ``baud``."""
    if baud <= 0:
        raise ValueError(f"baud must be > 0, not {baud}")
    return BITS_PER_CHAR / baud


def wire_time(chars: int, baud: int) -> float:
    """Seconds ``chars`` characters take on the line at ``baud``."""
    return chars * char_time(baud)


def ack_chars(framing: Framing, sent_len: int) -> int:
    """Longest reply to a general command (§9-2 form I and its modifiers).

    '>' alone; ER1 may add '@' (§10 ER); EL1 adds CR (§10 EL) and then SUM1 its checksum
    (§10 SUM: only CR-terminated replies carry one); EE1 replaces '>' by the echo of the
    whole frame (§10 EE).
    """
    error = 1 if framing.error_mark else 0
    if framing.echo:
        return sent_len + error + (1 if framing.cr_after_ack else 0)
    if framing.cr_after_ack:
        return 1 + error + (CHECKSUM_CHARS if framing.checksum else 0) + 1
    return 1 + error


def data_chars(fmt: ReplyFormat, framing: Framing, sent_len: int) -> int:
    """Longest reply to a query: '>' mark B# data CR (§9-2 form II), SUM1 + 2, EE1 echo first.

    With EE1 the echo replaces the '>' (§10 EE: echo part + the normal reply minus '>').
    ``IR`` has no fixed length: its longest reply (a full program) is taken.
    """
    plain = reply_length(fmt)
    length = _LONGEST_DATA if plain is None else plain
    if framing.echo:
        return sent_len + length - 1
    return length + (CHECKSUM_CHARS if framing.checksum else 0)


def reply_chars(command: Command, framing: Framing, sent_len: int) -> int:
    """Longest reply ``command`` can get with ``framing``, in characters."""
    fmt = command.reply_format
    if fmt.has_data:
        return data_chars(fmt, framing, sent_len)
    return ack_chars(framing, sent_len)


@dataclass(frozen=True)
class Timing:
    """Device time to host time, and the reply time-out of one exchange.

    ``turnaround``: device seconds a controller may take between the CR of a command and the
    first character of its reply (the manual gives no figure; a margin). ``host_latency``: real
    seconds the host adds (driver, USB-serial adapters, scheduling), not scaled.
    ``quiet_chars``: silence, in character times, after which a message in progress is over.
    """

    baud: int
    scale: float = 1.0
    turnaround: float = 0.010
    host_latency: float = 0.020
    quiet_chars: float = 3.0

    def __post_init__(self) -> None:
        if self.baud <= 0 or not self.scale > 0:
            raise ValueError("baud and scale must be > 0")
        if self.turnaround < 0 or self.host_latency < 0 or self.quiet_chars <= 0:
            raise ValueError("turnaround and host_latency must be >= 0, quiet_chars > 0")

    @property
    def char(self) -> float:
        """Device seconds of one character."""
        return char_time(self.baud)

    def wire(self, chars: int) -> float:
        """Device seconds of ``chars`` characters."""
        return wire_time(chars, self.baud)

    def reply_timeout(self, sent_len: int, reply_len: int) -> float:
        """Device seconds from the write until the whole reply must be in (DESIGN invariant 7)."""
        return self.wire(sent_len + reply_len) + self.turnaround

    def real(self, device_seconds: float) -> float:
        """Host seconds for a device duration: scaled, plus the host's latency."""
        return device_seconds / self.scale + self.host_latency

    def scaled(self, device_seconds: float) -> float:
        """Host seconds for a device duration, without the host latency."""
        return device_seconds / self.scale

    def quiet(self) -> float:
        """Host seconds of silence after which a message in progress is taken as ended."""
        return self.real(self.quiet_chars * self.char)

    def late_quiet(self, reply_len: int) -> float:
        """Host seconds of silence that ends the wait for a late reply.

        The longest possible reply time of the command (its longest reply, plus the
        turnaround): bytes that come later than that after a time-out belong to no exchange.
        """
        return self.real(self.wire(reply_len) + self.turnaround)

    def resync_quiet(self, sent_len: int = 0) -> float:
        """Host seconds of silence that bring the line back in step after a lost reply.

        The longest reply any controller of the loop can send (``LONGEST_FIXED_REPLY`` with a
        checksum, after the echo of a ``sent_len`` frame with EE1), plus the turnaround: a
        reply that has not begun by then belongs to no exchange any more (DESIGN invariant 13).
        """
        longest = sent_len + LONGEST_FIXED_REPLY + CHECKSUM_CHARS
        return self.real(self.wire(longest) + self.turnaround)
