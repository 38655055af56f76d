"""The controller's side of the line: the host's byte stream cut into command frames (§9-1, §11-3).

The simulator reads what the host writes with CommandReader: ``$`` or ``#`` B# text
[checksum] CR, the program text after ``I``, and the stray bytes between frames. The host's
own encoder and the reply helpers stay in ``framing``.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from gateway.protocol.framing import CR, MARKS, MAX_FRAME, Series, checksum, from_wire

__all__ = [
    "CommandEvent",
    "CommandFrame",
    "CommandReader",
    "RawText",
    "Stray",
]


@dataclass(frozen=True)
class CommandFrame:
    """One command as the controller reads it: mark, body, text, CR."""

    series: Series
    body: str
    text: str  # without the checksum when the body has SUM1
    #: None when the body has no checksum; False also when the frame is too short to carry one
    checksum_ok: bool | None
    raw: bytes


@dataclass(frozen=True)
class Stray:
    """Bytes outside any frame (a lone '/', LF after CR, a '$' CR), or a frame over MAX_FRAME."""

    raw: bytes


@dataclass(frozen=True)
class RawText:
    """Program text sent after ``I`` (§10 I, §11-3): everything up to CR, no '$' start."""

    series: Series
    body: str
    text: str
    raw: bytes
    #: False when a start mark cut the transfer short ('$' must not occur in a program, §11-3)
    complete: bool


CommandEvent = CommandFrame | Stray | RawText


class CommandReader:
    """Incremental reader of the host's byte stream, for the simulator. Never raises.

    ``push`` stores bytes and ``next_event`` parses only as far as the next event, so that a
    simulator can act on a frame (``SUM1`` turns checksums on, ``I`` starts program text) before
    the bytes behind it in the same chunk are read. ``feed`` does both at once.
    """

    def __init__(self) -> None:
        self._checksums: set[tuple[Series, str]] = set()
        self._input = bytearray()
        self._frame = bytearray()  # the frame, or the program text, read so far
        self._raw: tuple[Series, str] | None = None
        self._ready: deque[CommandEvent] = deque()

    def set_checksum(self, body: str, on: bool, *, series: Series = Series.DOLLAR) -> None:
        """Say whether frames for ``body`` carry a checksum (SUM1) from now on."""
        if on:
            self._checksums.add((series, body))
        else:
            self._checksums.discard((series, body))

    def begin_raw(self, body: str, *, series: Series = Series.DOLLAR) -> None:
        """Read the next bytes up to CR as program text for ``body`` (after ``I`` was taken)."""
        if self._frame:
            # Only when feed() read past the I frame: those bytes began another frame.
            self._ready.append(Stray(bytes(self._frame)))
            self._frame.clear()
        self._raw = (series, body)

    def push(self, data: bytes) -> None:
        """Store received bytes; ``next_event`` reads them."""
        self._input += data

    def feed(self, data: bytes) -> list[CommandEvent]:
        """Store ``data`` and return every event it completes."""
        self.push(data)
        events: list[CommandEvent] = []
        while (event := self.next_event()) is not None:
            events.append(event)
        return events

    def next_event(self) -> CommandEvent | None:
        """The next complete event, or None when the stored bytes hold no further one.

        Stray bytes are reported as soon as they are read (a run split across pushes gives one
        ``Stray`` per piece): the device ignores them, nothing waits for their end.
        """
        if self._ready:
            return self._ready.popleft()
        stray = bytearray()
        pos = 0
        event: CommandEvent | None = None
        while pos < len(self._input) and event is None:
            byte = self._input[pos]
            if byte in MARKS and (self._raw is not None or self._frame or stray):
                # A start mark ends whatever came before it and is read again as a frame start:
                # the device takes '$' as a command start anywhere, even in a program (§10 I).
                if stray:
                    break
                event = self._end_raw(complete=False) if self._raw else self._abandon()
                continue
            pos += 1
            if self._raw is not None:
                if byte == CR[0]:
                    event = self._end_raw(complete=True)
                else:
                    self._frame.append(byte)
            elif self._frame or byte in MARKS:
                event = self._frame_byte(byte)
            else:
                stray.append(byte)
                if byte == CR[0]:
                    break
        del self._input[:pos]
        return Stray(bytes(stray)) if stray else event

    def _abandon(self) -> Stray:
        stray = Stray(bytes(self._frame))
        self._frame.clear()
        return stray

    def _end_raw(self, *, complete: bool) -> RawText:
        assert self._raw is not None
        series, body = self._raw
        raw = bytes(self._frame) + (CR if complete else b"")
        text = from_wire(bytes(self._frame))
        self._frame.clear()
        self._raw = None
        return RawText(series, body, text, raw, complete)

    def _frame_byte(self, byte: int) -> CommandEvent | None:
        self._frame.append(byte)
        if byte != CR[0]:
            return self._abandon() if len(self._frame) > MAX_FRAME else None
        raw = bytes(self._frame)
        self._frame.clear()
        if len(raw) < 3:
            return Stray(raw)  # mark CR: no body number
        series = Series(chr(raw[0]))
        body = from_wire(raw[1:2])
        content = raw[2:-1]
        ok: bool | None = None
        if (series, body) in self._checksums:
            ok = len(content) >= 2 and content[-2:] == checksum(raw[:-3])
            if len(content) >= 2:
                content = content[:-2]
        return CommandFrame(series, body, from_wire(content), ok, raw)
