"""Wire framing of the RC-233 (§9-1, §9-2, §10 EE/EL/ER/SUM, §11-3, §12 /CO /CC), sans-I/O.

Host side: ``encode_command`` writes ``$`` B# text [checksum] CR (§9-1, §10 SUM).
Device side (the simulator): the ``encode_*`` reply helpers write exactly what the controller
sends for every combination of the framing switches (``command_reader`` cuts the host's byte
stream into command frames). The reply *parser* of the host lives in ``reply_parser``.

The choices where the manual is silent are in ``docs/manual-notes.md`` ("Framing and the
reply stream"); the ones that decide bytes here: a '#'-series controller answers with '#'
where the '$' series writes '$'; '?' and the one-character replies never carry a checksum or
CR; with EE1 + EL1 a general reply is the echo followed by CR; the reply to ``SUM1``/``EE1``/
``EE0`` uses the framing in force when the command arrived, the reply to ``EL1``/``EL0`` the
new one (§10 EL says so).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from enum import StrEnum
from types import MappingProxyType

from gateway.errors import ParameterError

__all__ = [
    "BAUD_RATES",
    "BITS_PER_CHAR",
    "BODY_NUMBERS",
    "CR",
    "EEPROM_DONE",
    "MARKS",
    "MAX_FRAME",
    "POWER_ON",
    "PROGRAM_ERROR",
    "SWITCH_FIELDS",
    "TIMER_UP",
    "Framing",
    "FramingSwitch",
    "Series",
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


#: The start marks of a frame: the "$" series and the "#" series (§9-1).
MARKS = frozenset(b"$#")


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


#: Each framing switch's command name -> the ``Framing`` field it sets: the one table of it
#: (the catalog's framing forms, the simulator's queries and the gateway's rules derive from
#: it). §10 names them "E E" エコーバック機能 (the echo), "E L" キャリッジ・リターン追加機能 (a CR
#: after '>'), "E R" エラー表示機能 ('>@' on a command error) and "S U M" サム・チェック機能
#: (checksums).
SWITCH_FIELDS: Mapping[str, str] = MappingProxyType(
    {"EE": "echo", "EL": "cr_after_ack", "ER": "error_mark", "SUM": "checksum"}
)


def framing_switch(framing: Framing, text: str) -> FramingSwitch:
    """Apply the command ``text`` (after the body number) to ``framing``.

    EL changes its own reply (§10 EL: the reply to EL1 is already '>' CR); EE, ER and SUM take
    effect from the next command (§10 EE: EE1 is answered '>', EE0 with its echo; §10 SUM "以後の
    コマンド"). Texts other than the eight switch settings change nothing.
    """
    name, value = text[:-1], text[-1:]
    if name not in SWITCH_FIELDS or value not in ("0", "1"):
        return FramingSwitch(framing, framing)
    on = value == "1"
    if on and ((name == "EE" and framing.checksum) or (name == "SUM" and framing.echo)):
        return FramingSwitch(framing, framing, refused=True)
    after = replace(framing, **{SWITCH_FIELDS[name]: on})
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
