"""The line trace of one loop: what went out and came in, when, for diagnosing a site.

Switched at run time for the whole loop or per controller. Bytes
received are attributed to the controller of the exchange in progress, or to the controller an
unsolicited message names. The record is bounded by count and by bytes (``TRACE_BYTES``:
a chunk of noise or a long note weighs more than a frame): the oldest entries go first.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from enum import StrEnum

from gateway.rings import BoundedRing

__all__ = ["TRACE_BYTES", "FrameDirection", "LineTrace", "TraceRecord"]

#: bytes the trace keeps at most, counting each record as its data, its note and a fixed
#: ``_RECORD_COST`` for the record itself
TRACE_BYTES = 1024 * 1024
_RECORD_COST = 100


class FrameDirection(StrEnum):
    """Which way bytes went, or what happened to them."""

    TX = "tx"  # written to the line
    RX = "rx"  # received
    DISCARD = "discard"  # received, dropped as stale before a send
    NOTE = "note"  # a scheduler remark (time-out, late reply, link down ...)


@dataclass(frozen=True)
class TraceRecord:
    """One traced chunk: host clock time, direction, controller (None: not known), bytes."""

    time: float
    direction: FrameDirection
    body: str | None
    data: bytes
    note: str = ""

    def ascii(self) -> str:
        """The bytes as text, control characters escaped (CR as ``\\r``)."""
        return "".join(
            chr(b) if 0x20 <= b < 0x7F else ("\\r" if b == 0x0D else f"\\x{b:02x}")
            for b in self.data
        )

    def hex(self) -> str:
        """The bytes as spaced hex pairs."""
        return self.data.hex(" ")

    def format(self, hex_mode: bool = False) -> str:
        """One line: time, direction, body, bytes (ASCII or hex) and note."""
        text = self.hex() if hex_mode else self.ascii()
        body = self.body if self.body is not None else "-"
        note = f"  # {self.note}" if self.note else ""
        return f"{self.time:.6f} {self.direction.value:7} {body} {text}{note}"


class LineTrace:
    """Bounded trace; off until ``enable`` (whole loop) or ``enable_body`` (one controller)."""

    def __init__(self, size: int = 5000, max_bytes: int = TRACE_BYTES) -> None:
        self._records: BoundedRing[TraceRecord] = BoundedRing(size, max_bytes, _record_size)
        self.all = False
        self.bodies: set[str] = set()
        self.hex_mode = False
        #: anything traced at all: the exchange path asks this before it builds a record
        #: (tracing is off on a running site, and a reply costs no call then)
        self.on = False

    def enable(self, on: bool = True, *, hex_mode: bool | None = None) -> None:
        """Trace every controller of the loop (or stop doing so)."""
        self.all = on
        self.on = self.all or bool(self.bodies)
        if hex_mode is not None:
            self.hex_mode = hex_mode

    def enable_body(self, body: str, on: bool = True) -> None:
        """Trace one controller (in addition to ``all``)."""
        if on:
            self.bodies.add(body)
        else:
            self.bodies.discard(body)
        self.on = self.all or bool(self.bodies)

    def wants(self, body: str | None) -> bool:
        """Whether bytes of ``body`` are traced now."""
        return self.all or (body is not None and body in self.bodies)

    def add(
        self, time: float, direction: FrameDirection, body: str | None, data: bytes, note: str = ""
    ) -> None:
        """Record a chunk if tracing is on for ``body``."""
        if self.wants(body):
            self._records.append(TraceRecord(time, direction, body, bytes(data), note))

    def records(self, body: str | None = None) -> list[TraceRecord]:
        """The records kept (of one controller)."""
        return [r for r in self._records if body is None or r.body == body]

    def lines(self, body: str | None = None) -> Iterator[str]:
        """The records as text lines, in the trace's ASCII/hex mode."""
        for record in self.records(body):
            yield record.format(self.hex_mode)

    def clear(self) -> None:
        """Forget the records."""
        self._records.clear()

    @property
    def kept(self) -> tuple[int, int]:
        """Records kept and their bytes (as ``TRACE_BYTES`` counts them)."""
        return len(self._records), self._records.nbytes


def _record_size(record: TraceRecord) -> int:
    return _RECORD_COST + len(record.data) + len(record.note)
