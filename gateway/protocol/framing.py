"""Wire framing of the RC-233 (§9-1, §9-2, §10 EE/EL/ER/SUM, §11-3, §12 /CO /CC), sans-I/O.

Host side: ``encode_command`` writes ``$`` B# text [checksum] CR (§9-1, §10 SUM).
Device side (the simulator): the ``encode_*`` reply helpers write exactly what the controller
sends for every combination of the framing switches, and ``CommandReader`` cuts the host's byte
stream into command frames. The reply *parser* of the host lives in ``reply_parser``.

The choices where the manual is silent are in ``docs/manual-notes.md`` ("Framing and the
reply stream"); the ones that decide bytes here: a '#'-series controller answers with '#'
where the '$' series writes '$'; '?' and the one-character replies never carry a checksum or
CR; with EE1 + EL1 a general reply is the echo followed by CR; the reply to ``SUM1``/``EE1``/
``EE0`` uses the framing in force when the command arrived, the reply to ``EL1``/``EL0`` the
new one (§10 EL says so).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace
from enum import StrEnum

from gateway.errors import ParameterError

__all__ = [
    "BAUD_RATES",
    "BITS_PER_CHAR",
    "BODY_NUMBERS",
    "CR",
    "EEPROM_DONE",
    "MAX_FRAME",
    "POWER_ON",
    "PROGRAM_ERROR",
    "TIMER_UP",
    "CommandEvent",
    "CommandFrame",
    "CommandReader",
    "Framing",
    "FramingSwitch",
    "RawText",
    "Series",
    "Stray",
    "checksum",
    "encode_ack",
    "encode_command",
    "encode_data",
    "encode_not_accepted",
    "encode_program_error",
    "encode_program_message",
    "encode_unsolicited",
    "framing_switch",
    "from_wire",
    "to_wire",
]

CR = b"\r"
#: Bits a character takes on the line: start, 8 data, stop (§2 仕様: 8N1, no parity).
BITS_PER_CHAR = 10
#: The line rates, indexed by the digit of ``ES`` (§2 仕様 "9600, 1200, 300bps"; §10 ES 0/1/2).
BAUD_RATES = (9600, 1200, 300)
#: Body numbers a host may address; 'F' is the inspection mode that echoes everything (§3-III).
BODY_NUMBERS = "0123456789ABCDE"
#: The text after ``$B#`` of the unsolicited messages of §10 AW/DW/IW/EE/// and §10 T.
EEPROM_DONE = "*"
TIMER_UP = "T"
#: What a running user program sends on a command error with ER1 (§10 ER 注意点).
PROGRAM_ERROR = b"@"
#: Longest command frame the reader keeps; the longest real command is far shorter (§10).
MAX_FRAME = 256

_KANA_FIRST, _KANA_LAST = 0xFF61, 0xFF9F  # half-width katakana, JIS X 0201 0xA1-0xDF
_KANA_OFFSET = _KANA_FIRST - 0xA1
_YEN = "\u00a5"


class Series(StrEnum):
    """The start mark of a controller (§9-1 注意): standard '$', special order '#'."""

    DOLLAR = "$"
    HASH = "#"

    @property
    def mark(self) -> bytes:
        """The start mark as one byte."""
        return self.value.encode("ascii")


_MARKS = frozenset(b"$#")


def to_wire(text: str) -> bytes:
    """Encode text for the line: ASCII, half-width katakana as JIS X 0201, '¥' as 0x5C."""
    out = bytearray()
    for ch in text:
        code = ord(ch)
        if code < 0x80:
            out.append(code)
        elif _KANA_FIRST <= code <= _KANA_LAST:
            out.append(code - _KANA_OFFSET)
        elif ch == _YEN:
            out.append(0x5C)  # JIS X 0201 puts '¥' where ASCII has '\'
        else:
            raise ValueError(f"{ch!r} has no single-byte code on the RC-233 line")
    return bytes(out)


def from_wire(data: bytes) -> str:
    """Decode line bytes; bytes >= 0x80 outside the katakana range become U+FFFD. Never raises."""
    chars: list[str] = []
    for byte in data:
        if byte < 0x80:
            chars.append(chr(byte))
        elif 0xA1 <= byte <= 0xDF:
            chars.append(chr(byte + _KANA_OFFSET))
        else:
            chars.append("\ufffd")
    return "".join(chars)


def checksum(body: bytes) -> bytes:
    """Two upper-case hex digits of the low byte of the byte sum (§10 SUM: 10Fh -> '0F')."""
    return b"%02X" % (sum(body) & 0xFF)


@dataclass(frozen=True)
class Framing:
    """The four framing switches of one controller; the default is the factory setting."""

    echo: bool = False  # EE1 (§10 EE)
    cr_after_ack: bool = False  # EL1 (§10 EL)
    error_mark: bool = False  # ER1 (§10 ER, ROM 1.19+)
    checksum: bool = False  # SUM1 (§10 SUM)

    def __post_init__(self) -> None:
        if self.echo and self.checksum:
            # §10 EE and §10 SUM 注意点: the two cannot be set at the same time.
            raise ValueError("EE1 and SUM1 cannot be on together (§10 EE, §10 SUM)")


#: The factory setting (§16): every switch off. DW stores the switches in EEPROM (§10 DW), so a
#: controller may come up with some of them on.
POWER_ON = Framing()


@dataclass(frozen=True)
class FramingSwitch:
    """What a framing command does: the framing of its own reply and the one after it."""

    reply: Framing
    after: Framing
    #: EE1 while SUM1 is on, or SUM1 while EE1 is on: a command error, nothing changes
    refused: bool = False


_SWITCHES = {
    "EE": "echo",
    "EL": "cr_after_ack",
    "ER": "error_mark",
    "SUM": "checksum",
}


def framing_switch(framing: Framing, text: str) -> FramingSwitch:
    """Apply the command ``text`` (after the body number) to ``framing``.

    EL changes its own reply (§10 EL: the reply to EL1 is already '>' CR); EE, ER and SUM take
    effect from the next command (§10 EE: EE1 is answered '>', EE0 with its echo; §10 SUM "以後の
    コマンド"). Texts other than the eight switch settings change nothing.
    """
    name, value = text[:-1], text[-1:]
    if name not in _SWITCHES or value not in ("0", "1"):
        return FramingSwitch(framing, framing)
    on = value == "1"
    if on and ((name == "EE" and framing.checksum) or (name == "SUM" and framing.echo)):
        return FramingSwitch(framing, framing, refused=True)
    after = replace(framing, **{_SWITCHES[name]: on})
    return FramingSwitch(after if name == "EL" else framing, after)


def _check_body(body: str) -> None:
    if len(body) != 1 or body not in BODY_NUMBERS:
        raise ParameterError(
            f"body number {body!r} is not one of 0-E",
            field="body",
            rule="one character 0-9 or A-E (§9-1; F is the inspection mode)",
        )


def encode_command(
    body: str, text: str, *, series: Series = Series.DOLLAR, framing: Framing = POWER_ON
) -> bytes:
    """Frame a host command: mark + body + text [+ checksum] + CR (§9-1, §10 SUM).

    Refuses '$', '#', CR and LF in the text: a start mark inside a frame starts a new command
    on every controller of its series, and CR ends the frame early (§9-1, §13-1).
    """
    _check_body(body)
    if any(ch in text for ch in "$#\r\n"):
        raise ParameterError(
            f"command text {text!r} contains a start mark or a line end",
            field="text",
            rule="no '$', '#', CR or LF inside a command (§9-1)",
        )
    try:
        payload = series.mark + body.encode("ascii") + to_wire(text)
    except ValueError as exc:
        raise ParameterError(
            str(exc), field="text", rule="ASCII, half-width katakana or '¥' only (§9-1 注意)"
        ) from exc
    if framing.checksum:
        payload += checksum(payload)
    return payload + CR


def _line(content: bytes, framing: Framing) -> bytes:
    """A CR-terminated device message; SUM1 puts the checksum of everything before it."""
    if framing.checksum:
        content += checksum(content)
    return content + CR


def encode_ack(framing: Framing, *, sent: bytes, error: bool = False) -> bytes:
    """The reply to a general command: '>' or, with ``error`` and ER1, '>@'.

    ``sent`` is the command exactly as received; with EE1 it is echoed instead of '>' (§10 EE).
    EL1 ends the reply with CR (after the echo as well: the "normal reply minus '>'" of '>' CR is
    CR); SUM1 adds a checksum only to CR-terminated replies (§10 SUM 受信フォーマット).
    """
    mark = b"@" if error and framing.error_mark else b""
    if framing.echo:
        return sent + mark + (CR if framing.cr_after_ack else b"")
    if framing.cr_after_ack:
        return _line(b">" + mark, framing)
    return b">" + mark


def encode_data(
    body: str,
    data: str,
    framing: Framing,
    *,
    series: Series = Series.DOLLAR,
    sent: bytes,
) -> bytes:
    """The reply to a query: '>' mark B# data [checksum] CR, or with EE1 the echo then the rest."""
    _check_body(body)
    part = series.mark + body.encode("ascii") + to_wire(data)
    if framing.echo:
        return sent + part + CR
    return _line(b">" + part, framing)


def encode_not_accepted() -> bytes:
    """'?': communication abnormality or a bad command checksum (§9-2, §10 SUM); never CR."""
    return b"?"


def encode_unsolicited(
    body: str, message: str, framing: Framing, *, series: Series = Series.DOLLAR
) -> bytes:
    """An unsolicited mark B# message [checksum] CR.

    ``message`` is ``EEPROM_DONE`` ('*', §10 AW/DW/IW/EE///), ``TIMER_UP`` ('T', §10 T) or the
    data of a query a user program ran (§11-3: the normal reply without '>').
    """
    _check_body(body)
    return _line(series.mark + body.encode("ascii") + to_wire(message), framing)


def encode_program_message(text: str, framing: Framing) -> bytes:
    """'>' text [checksum] CR: ``/CO`` text (§12), or ``/CC`` with text '$' B# CT nnnnn."""
    return _line(b">" + to_wire(text), framing)


def encode_program_error() -> bytes:
    """The lone '@' of a user program that hit a command error with ER1 (§10 ER)."""
    return PROGRAM_ERROR


# --------------------------------------------------------------------------- command reader


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
            if byte in _MARKS and (self._raw is not None or self._frame or stray):
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
            elif self._frame or byte in _MARKS:
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
