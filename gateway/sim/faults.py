"""Faults the simulated line can inject: per-reply line faults and device events, so that
the gateway is tested against the line a factory really has.

A ``FaultRule`` names a fault, the controllers it hits (``body``; None = all) and when: with a
``probability`` per command frame the controller answers, and/or as ``shots`` one-shots that
hit the next frames for sure. ``Faults.draw`` rolls the rules for one frame with one seedable
``random.Random``, so a run with the same seed and the same host bytes injects the same faults.

Line faults (at most one per reply; the first in ``LINE_FAULTS`` order wins):

* ``nak``: the frame reaches the controller as noise. It does not execute it, answers '?' and
  sets its communication-error flag (§9-2: '?' = a communication abnormality; §10 9 bit 0).
* ``drop``: the controller executes the frame; its reply is lost on the line.
* ``garble``: the controller executes; one bit of its reply is flipped on the line.
* ``late``: the controller executes; its reply leaves ``delay`` seconds later than normal.

Device events (applied once the reply has left, so that a move the host started is hit while
it runs): ``power`` (off for ``hold`` s, then on), ``ems`` (pressed for ``hold`` s),
``sensor`` (``sensor`` of ``motor`` forced to ``on`` for ``hold`` s), ``slip`` (``pulses``
lost on ``motor``), ``cut`` (the line cut for ``hold`` s). The same events exist as direct
operations on ``SimLoop`` and on the control surface.

``uart_noise`` is what a UART makes of bytes sent at another baud rate (§10 ES: a controller at
another rate than the host cannot communicate); ``garble`` is the bit flip of ``garble``.
"""

from __future__ import annotations

import dataclasses
import random
from dataclasses import dataclass, field
from enum import StrEnum
from fractions import Fraction

__all__ = [
    "DEVICE_FAULTS",
    "LINE_FAULTS",
    "Draw",
    "FaultKind",
    "FaultRule",
    "Faults",
    "garble",
    "uart_noise",
]


class FaultKind(StrEnum):
    """Every fault the line can inject."""

    NAK = "nak"
    DROP = "drop"
    GARBLE = "garble"
    LATE = "late"
    POWER = "power"
    EMS = "ems"
    SENSOR = "sensor"
    SLIP = "slip"
    CUT = "cut"


#: Faults on the reply itself, in order of precedence (a nak'd frame has no reply to drop).
LINE_FAULTS = (FaultKind.NAK, FaultKind.DROP, FaultKind.GARBLE, FaultKind.LATE)
#: Events that hit a controller or the whole line after the reply.
DEVICE_FAULTS = (
    FaultKind.POWER,
    FaultKind.EMS,
    FaultKind.SENSOR,
    FaultKind.SLIP,
    FaultKind.CUT,
)


@dataclass(frozen=True)
class FaultRule:
    """One injectable fault: what, on which controller, how likely, and its parameters."""

    kind: FaultKind
    probability: float = 0.0  # per command frame answered by a matching controller
    shots: int = 0  # the next `shots` matching frames get the fault for sure
    body: str | None = None  # None: every controller
    delay: float = 1.0  # late: extra seconds before the reply leaves
    hold: float = 0.5  # power: off time; ems: pressed time; sensor: forced time; cut: cut time
    motor: int = 1  # sensor, slip
    sensor: str = "org"  # sensor: the axis sensor name the controller knows
    on: bool = True  # sensor: forced ON or OFF
    pulses: int = 100  # slip: pulses lost (the mechanics lag the counter)

    def __post_init__(self) -> None:
        if not 0.0 <= self.probability <= 1.0:
            raise ValueError(f"probability must be within 0-1, not {self.probability}")
        if self.shots < 0:
            raise ValueError(f"shots must be >= 0, not {self.shots}")
        if self.delay < 0 or self.hold < 0:
            raise ValueError("delay and hold must be >= 0")
        if self.motor not in (1, 2):
            raise ValueError(f"motor must be 1 or 2, not {self.motor}")

    def matches(self, body: str) -> bool:
        """Whether the rule applies to the controller answering as ``body``."""
        return self.body is None or self.body == body

    @property
    def spent(self) -> bool:
        """A one-shot rule that has fired as often as it was armed for, with no probability."""
        return self.shots == 0 and self.probability == 0.0


@dataclass(frozen=True)
class Draw:
    """The faults drawn for one frame: at most one line fault, any number of device events."""

    line: FaultRule | None = None
    events: tuple[FaultRule, ...] = ()

    @property
    def kind(self) -> FaultKind | None:
        """The line fault's kind, if any."""
        return None if self.line is None else self.line.kind


@dataclass
class Faults:
    """The armed fault rules of a line and the random generator that rolls them."""

    seed: int | None = None
    rules: list[FaultRule] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.rng = random.Random(self.seed)

    def add(self, rule: FaultRule) -> None:
        """Arm a rule (rules add up: two nak rules give two chances)."""
        self.rules.append(rule)

    def clear(self, kind: FaultKind | None = None, body: str | None = None) -> int:
        """Disarm the rules of ``kind`` (None: all kinds) for ``body`` (None: any); the count."""
        keep = [
            r
            for r in self.rules
            if not ((kind is None or r.kind == kind) and (body is None or r.body == body))
        ]
        removed = len(self.rules) - len(keep)
        self.rules = keep
        return removed

    def draw(self, body: str) -> Draw:
        """Roll every rule that matches ``body`` for one frame; one-shots are used up."""
        line: FaultRule | None = None
        events: list[FaultRule] = []
        for kind in (*LINE_FAULTS, *DEVICE_FAULTS):
            for index, rule in enumerate(self.rules):
                if rule.kind != kind or not rule.matches(body):
                    continue
                if kind in LINE_FAULTS and line is not None:
                    break
                if self._fires(index, rule):
                    if kind in LINE_FAULTS:
                        line = rule
                    else:
                        events.append(rule)
        self.rules = [r for r in self.rules if not r.spent]
        return Draw(line, tuple(events))

    def _fires(self, index: int, rule: FaultRule) -> bool:
        if rule.shots > 0:
            self.rules[index] = dataclasses.replace(rule, shots=rule.shots - 1)
            return True
        return rule.probability > 0.0 and self.rng.random() < rule.probability

    def describe(self) -> list[dict[str, object]]:
        """The armed rules as JSON-ready data (for the control surface's ``state``)."""
        return [
            {k: (str(v) if isinstance(v, StrEnum) else v) for k, v in vars(r).items()}
            for r in self.rules
        ]


def garble(data: bytes, rng: random.Random) -> bytes:
    """``data`` with one bit flipped at a random position (empty data stays empty)."""
    if not data:
        return data
    out = bytearray(data)
    out[rng.randrange(len(out))] ^= 1 << rng.randrange(8)
    return bytes(out)


def _level(data: bytes, bit: int) -> int:
    """Line level during bit ``bit`` of ``data`` sent 8N1 (§2): start 0, LSB first, stop 1."""
    frame, pos = divmod(bit, 10)
    if bit < 0 or frame >= len(data) or pos == 9:
        return 1  # idle or stop bit
    if pos == 0:
        return 0
    return (data[frame] >> (pos - 1)) & 1


def uart_noise(data: bytes, sent_baud: int, heard_baud: int) -> bytes:
    """What a UART at ``heard_baud`` reads from ``data`` sent 8N1 at ``sent_baud``.

    The receiver waits for a falling edge, samples the middle of its start bit (a glitch
    shorter than half a bit is no start), of 8 data bits and of the stop bit, and delivers the
    byte even on a framing error (as a tty without INPCK does). Equal rates give ``data``.
    """
    if sent_baud == heard_baud:
        return data
    sent_bit = Fraction(1, sent_baud)
    heard_bit = Fraction(1, heard_baud)
    total_bits = len(data) * 10
    out = bytearray()
    scan = Fraction(0)  # the receiver looks for a start bit from here on

    def level_at(t: Fraction) -> int:
        return _level(data, int(t / sent_bit))

    bit = 0
    while True:
        # The next falling edge at or after `scan`: edges fall on sender bit boundaries.
        bit = max(bit, -(-scan // sent_bit))  # ceil
        bit = int(bit)
        while bit < total_bits and not (_level(data, bit - 1) == 1 and _level(data, bit) == 0):
            bit += 1
        if bit >= total_bits:
            return bytes(out)
        start = bit * sent_bit
        if level_at(start + heard_bit / 2) != 0:
            scan = start + heard_bit / 2
            bit += 1
            continue
        value = 0
        for k in range(8):
            value |= level_at(start + heard_bit * (k + Fraction(3, 2))) << k
        out.append(value)
        scan = start + heard_bit * Fraction(19, 2)  # the stop-bit sample
        bit += 1
