"""Incremental, sans-I/O parser of what RC-233 controllers send to the host.

The caller configures the parser with the controller's ``Framing`` and ``Series``, calls
``expect()`` before each command, feeds received bytes with ``feed()`` and calls ``line_quiet()``
when the line has been silent for a while. Every event carries the bytes it came from and
``is_reply``: True when it answers the pending command (good or bad), which ends the expectation.
Nothing here raises on device input.

Rules and where they come from:

* §9-2: a general command is answered '>' (no CR), a query '>' mark B# data CR, a communication
  fault '?' (no CR). Whether '>' is followed by data is not in the bytes, hence ``expect()``.
* §10 EL: with EL1 the general reply is '>' CR; query replies do not change.
* §10 ER: with ER1 a command error is answered '>@' (CR only with EL1); a running user program
  that hits a command error sends a lone '@'.
* §10 EE: with EE1 the reply is the command exactly as received, then the normal reply minus
  '>'; nothing follows the echo when the normal reply is '>'. An echo that differs from
  ``sent`` is ``Garbled`` (detecting that is what the echo is for).
* §10 SUM: with SUM1 every message that ends with CR carries two hex digits before the CR, the
  sum of everything before them, '>' included; '>' alone and '?' carry none (with EL1 '>' is
  '>3E' CR). A wrong sum is ``ChecksumMismatch``.
* §10 AW/DW/IW/EE///, §10 T, §11-3, §12 /CO /CC: unsolicited '$B#*' CR, '$B#T' CR, a program's
  query output '$B#data' CR, '>text' CR and '>$B#...' CR. They never answer a command and
  do not end the expectation.

Ambiguous in the manual, decided in ``docs/manual-notes.md`` ("Framing and the reply stream"):

* With ER1 and EL0, '>' may be followed by '@'; the parser decides on the next byte or at
  ``line_quiet()``. With EL0 a '>' while a query is pending likewise waits (the device answers a
  query it refused with a bare '>'). EL1 removes both waits.
* With EL0 a program's '>text' CR cannot be told from a '>' reply followed by text by the
  bytes alone. While a user program may print (``configure(printing=True)``: the scheduler
  knows), '>' followed by a byte that starts no message is a ``/CO`` line and the expectation
  stays; the '>' of a general command then waits for its next byte too. Otherwise the pending
  command wins ('>' answers, the rest is ``Garbled``). A '>$B#...' CR (``/CC``) while a query
  of that controller is pending is its data reply.
* '$B#*' and '$B#T' are always unsolicited: no query returns the data '*' or 'T' (§10).
  With SUM1 they are accepted with or without a checksum (the manual does not say).
* With EE1 + EL1 a general reply is accepted as the echo alone or the echo followed by CR.
* '$' never occurs inside a device message (§11-3: not even in program text), so it restarts
  a message; '#' restarts a message that began with a start mark. '>', '?', '@' do not:
  they occur in /CO text and in echoed labels.
"""

from __future__ import annotations

import re
from enum import Enum, auto

from gateway.protocol.framing import BODY_NUMBERS, POWER_ON, Framing, Series, checksum, from_wire
from gateway.protocol.reply_events import (
    Accepted,
    ChecksumMismatch,
    CommandRejected,
    DataReply,
    Expectation,
    Garbled,
    NotAccepted,
    ReplyEvent,
    Unsolicited,
    UnsolicitedKind,
    device_report,
    program_output,
)

__all__ = [
    "MAX_LINE",
    "Accepted",
    "ChecksumMismatch",
    "CommandRejected",
    "DataReply",
    "Expectation",
    "Garbled",
    "NotAccepted",
    "ReplyEvent",
    "ReplyParser",
    "Unsolicited",
    "UnsolicitedKind",
]

#: Longest message kept before it is reported Garbled: IR returns up to 4,416 program bytes.
MAX_LINE = 4608

_CR, _GT, _QUESTION, _AT, _DOLLAR, _HASH = b"\r>?@$#"
_MARKS = frozenset(b"$#")
_STARTS = frozenset(b">?@$#")
#: The bytes that end or restart a line (``_line``); any other is only kept.
_LINE_STOP = re.compile(rb"[\r$#]")


class _State(Enum):
    IDLE = auto()  # between messages (after a matched echo: waiting for the response part)
    GARBAGE = auto()  # bytes that start no message, up to CR or a start character
    GT = auto()  # '>' with EL0, waiting for the next byte to decide
    LINE = auto()  # a message that ends with CR
    ECHO_AT = auto()  # echo + '@' with EL1, waiting for its CR


class ReplyParser:
    """Incremental parser of the device-to-host byte stream of one RS-232C line."""

    def __init__(self, framing: Framing = POWER_ON, series: Series = Series.DOLLAR) -> None:
        self._framing = framing
        self._series = series
        self._exp: Expectation | None = None
        self._state = _State.IDLE
        self._buf = bytearray()
        self._echo: bytes | None = None  # a matched echo whose response part has not come
        self._printing = False  # a user program may print '>text' CR (configure)

    @property
    def framing(self) -> Framing:
        """The controller's framing: used for the next expectation and for unsolicited bytes."""
        return self._framing

    @property
    def series(self) -> Series:
        """The controller's series."""
        return self._series

    @property
    def pending(self) -> Expectation | None:
        """The reply still awaited, if any."""
        return self._exp

    def configure(
        self,
        framing: Framing | None = None,
        series: Series | None = None,
        *,
        printing: bool | None = None,
    ) -> None:
        """Change the controller's framing or series (after EE/EL/ER/SUM took effect).

        ``printing``: a user program on the line may be printing ``/CO`` lines; with EL0 the
        '>' of a general command then waits for the next byte (text makes it a ``/CO`` line),
        which costs a quiet period on every such reply, so it is on only while it may matter.
        """
        if framing is not None:
            self._framing = framing
        if series is not None:
            self._series = series
        if printing is not None:
            self._printing = printing

    def expect(
        self, body: str, sent: bytes, has_data: bool, *, framing: Framing | None = None
    ) -> None:
        """Wait for the reply to ``sent`` from ``body`` (call it before sending).

        ``has_data``: a query reply '>$B#data' CR rather than '>'. ``framing`` overrides the
        controller's framing for this one reply (``framing_switch(...).reply``). A message
        partly read before the call is judged with the new expectation.
        """
        fr = self._framing if framing is None else framing
        if len(body) != 1 or body not in BODY_NUMBERS:
            raise ValueError(f"body number {body!r} is not one of 0-E")
        if fr.echo and not sent:
            raise ValueError("with EE1 the reply starts with the echo of `sent`")
        self._exp = Expectation(body, bytes(sent), has_data, fr, self._series)
        self._echo = None

    def cancel(self) -> None:
        """Stop waiting (the caller gave up on the reply); later replies come as is_reply=False."""
        self._exp = None
        self._echo = None

    @property
    def at_rest(self) -> bool:
        """Between messages with nothing held: ``line_quiet`` would end nothing now."""
        return self._state is _State.IDLE and self._echo is None

    def feed(self, data: bytes) -> list[ReplyEvent]:
        """Parse received bytes; returns the events they complete, in order."""
        out: list[ReplyEvent] = []
        i, end = 0, len(data)
        while i < end:
            if self._state is _State.LINE:
                # The body of a line straight from the bytes: every byte up to the next one
                # that can end or restart it (CR, '$', '#') is only kept (``_line``).
                found = _LINE_STOP.search(data, i)
                stop = end if found is None else found.start()
                room = MAX_LINE - len(self._buf)
                if stop > i and room > 0:
                    take = min(stop - i, room)
                    self._buf += data[i : i + take]
                    i += take
                    continue
            byte = data[i]
            while not self._step(byte, out):
                pass  # the byte ended the message before it; read it again from the new state
            i += 1
        return out

    def line_quiet(self) -> list[ReplyEvent]:
        """The line has been silent: end the message in progress, whatever it is."""
        out: list[ReplyEvent] = []
        echo = self._echo or b""
        if self._state is _State.GARBAGE:
            self._emit(out, Garbled(raw=bytes(self._buf)))
        elif self._state is _State.GT:
            self._emit(out, Accepted(raw=b">", is_reply=self._answers_gt()))
        elif self._state is _State.LINE:
            self._emit(out, Garbled(raw=echo + self._buf, is_reply=self._claims(self._buf)))
        elif self._state is _State.ECHO_AT:
            self._emit(out, CommandRejected(raw=echo + b"@", is_reply=True))
        elif self._echo is not None:
            self._emit(out, Accepted(raw=echo, is_reply=True))
        self._to_idle()
        return out

    # ------------------------------------------------------------------ state machine

    @property
    def _fr(self) -> Framing:
        return self._exp.framing if self._exp is not None else self._framing

    def _answers_gt(self) -> bool:
        """'>' forms answer the pending command unless EE1 replaces '>' by the echo."""
        return self._exp is not None and not self._exp.framing.echo

    def _claims(self, buf: bytes | bytearray) -> bool:
        """Whether an unfinished or corrupted message is the pending command's reply."""
        exp = self._exp
        if exp is None:
            return False
        if self._echo is not None:
            return True
        if exp.framing.echo:
            return exp.sent.startswith(bytes(buf))
        if buf[:1] != b">":
            return False
        if exp.has_data:
            return (b">" + exp.series.mark + exp.body.encode()).startswith(bytes(buf[:3]))
        return len(buf) < 2 or buf[1] not in _MARKS

    def _emit(self, out: list[ReplyEvent], event: ReplyEvent) -> None:
        out.append(event)
        if event.is_reply:
            self._exp = None
            self._echo = None

    def _to_idle(self) -> None:
        self._state = _State.IDLE
        self._buf.clear()

    def _start(self, state: _State, byte: int) -> None:
        self._state = state
        self._buf[:] = bytes([byte])

    def _step(self, byte: int, out: list[ReplyEvent]) -> bool:
        """Handle one byte; False when it must be read again in the new state."""
        if self._state is _State.GARBAGE:
            return self._garbage(byte, out)
        if self._state is _State.GT:
            return self._gt(byte, out)
        if self._state is _State.LINE:
            return self._line(byte, out)
        if self._state is _State.ECHO_AT:
            raw = (self._echo or b"") + b"@"
            if byte == _CR:
                self._to_idle()
                self._emit(out, CommandRejected(raw=raw + b"\r", is_reply=True))
                return True
            self._to_idle()
            self._emit(out, CommandRejected(raw=raw, is_reply=True))
            return False
        if self._echo is not None:
            return self._after_echo(byte, out)
        self._idle(byte, out)
        return True

    def _idle(self, byte: int, out: list[ReplyEvent]) -> None:
        exp = self._exp
        if byte == _GT:
            if self._fr.cr_after_ack:
                self._start(_State.LINE, byte)  # every '>' message ends with CR
            elif self._answers_gt() and exp is not None and not exp.has_data:
                if self._fr.error_mark or self._printing:
                    self._start(_State.GT, byte)  # '@' may follow, or /CO text
                else:
                    self._emit(out, Accepted(raw=b">", is_reply=True))
            else:
                self._start(_State.GT, byte)
        elif byte == _QUESTION:
            # '?' comes alone, also with EE1: the device did not take the frame as a command.
            self._emit(out, NotAccepted(raw=b"?", is_reply=exp is not None))
        elif byte == _AT:
            self._emit(out, program_output(b"@", None, None, "@"))
        elif byte in _MARKS:
            self._start(_State.LINE, byte)
        else:
            self._start(_State.GARBAGE, byte)
            if byte == _CR:
                self._emit(out, Garbled(raw=b"\r"))
                self._to_idle()

    def _garbage(self, byte: int, out: list[ReplyEvent]) -> bool:
        if byte in _STARTS:
            self._emit(out, Garbled(raw=bytes(self._buf)))
            self._to_idle()
            return False
        self._buf.append(byte)
        if byte == _CR or len(self._buf) >= MAX_LINE:
            self._emit(out, Garbled(raw=bytes(self._buf)))
            self._to_idle()
        return True

    def _gt(self, byte: int, out: list[ReplyEvent]) -> bool:
        """'>' with EL0: '@' makes '>@'; a mark starts a query reply or /CC; CR '>' CR."""
        answers = self._answers_gt()
        if byte == _AT:
            self._to_idle()
            self._emit(out, CommandRejected(raw=b">@", is_reply=answers))
            return True
        exp = self._exp if answers else None
        if exp is not None:
            # While a program may print, text (a byte that starts no message) after '>' is a
            # /CO line: the reply is '>' then silence, a start character, CR or the query's
            # data. Otherwise such text is a damaged reply, and the '>' answers.
            co_text = self._printing and byte not in _STARTS and byte != _CR
            continues = byte == _CR or co_text or (exp.has_data and byte in _MARKS)
        else:
            continues = byte not in (_GT, _QUESTION)  # '>text' CR of /CO
        if continues:
            self._state = _State.LINE
            return self._line(byte, out)
        self._to_idle()
        self._emit(out, Accepted(raw=b">", is_reply=answers))
        return False

    def _after_echo(self, byte: int, out: list[ReplyEvent]) -> bool:
        exp, echo = self._exp, self._echo
        assert exp is not None and echo is not None
        if byte == _AT:
            if exp.framing.cr_after_ack:
                self._state = _State.ECHO_AT
            else:
                self._emit(out, CommandRejected(raw=echo + b"@", is_reply=True))
            return True
        if byte == _CR and exp.framing.cr_after_ack:
            self._emit(out, Accepted(raw=echo + b"\r", is_reply=True))
            return True
        if byte in _MARKS and exp.has_data:
            self._start(_State.LINE, byte)
            return True
        self._emit(out, Accepted(raw=echo, is_reply=True))
        return False

    def _line(self, byte: int, out: list[ReplyEvent]) -> bool:
        buf = self._buf
        restarts = (byte == _DOLLAR and bytes(buf) != b">") or (byte == _HASH and buf[0] in _MARKS)
        if restarts or len(buf) >= MAX_LINE:
            echo = self._echo or b""
            self._emit(out, Garbled(raw=echo + buf, is_reply=self._claims(buf)))
            self._to_idle()
            return False
        buf.append(byte)
        if byte == _CR:
            line = bytes(buf)
            self._to_idle()
            self._finish(line, out)
        return True

    def _finish(self, line: bytes, out: list[ReplyEvent]) -> None:
        content = line[:-1]
        bare = len(content) == 3 and content[0] in _MARKS and content[2:] in (b"*", b"T")
        if self._fr.checksum and not bare:
            if len(content) < 3 or content[-2:] != checksum(content[:-2]):
                self._emit(out, ChecksumMismatch(raw=line, is_reply=self._claims(content)))
                return
            content = content[:-2]
        if content[0] == _GT:
            self._finish_gt(content, line, out)
        else:
            self._finish_marked(content, line, out)

    def _finish_gt(self, content: bytes, line: bytes, out: list[ReplyEvent]) -> None:
        answers = self._answers_gt()
        exp = self._exp
        if content == b">":
            self._emit(out, Accepted(raw=line, is_reply=answers))
        elif content == b">@":
            self._emit(out, CommandRejected(raw=line, is_reply=answers))
        elif content[1] not in _MARKS:
            self._emit(out, program_output(line, None, None, from_wire(content[1:])))
        elif len(content) < 3:
            self._emit(out, Garbled(raw=line))  # '>$' CR: no body number
        else:
            series, body, data = Series(chr(content[1])), from_wire(content[2:3]), content[3:]
            if answers and exp is not None and exp.has_data and exp.is_from(series, body):
                self._emit(out, DataReply(raw=line, is_reply=True, body=body, data=from_wire(data)))
            else:
                self._emit(out, program_output(line, series, body, from_wire(data)))

    def _finish_marked(self, content: bytes, line: bytes, out: list[ReplyEvent]) -> None:
        exp = self._exp
        if len(content) < 2:
            self._emit(out, Garbled(raw=line))  # mark CR: no body number
            return
        series, body, rest = Series(chr(content[0])), from_wire(content[1:2]), content[2:]
        echoing = exp is not None and exp.framing.echo
        if echoing and self._echo is None and exp is not None and line == exp.sent:
            fr = exp.framing
            if exp.has_data or fr.error_mark or fr.cr_after_ack:
                self._echo = line  # the response part, '@' or CR may follow
            else:
                self._emit(out, Accepted(raw=line, is_reply=True))
        elif rest in (b"*", b"T"):
            self._emit(out, device_report(line, series, body, rest))
        elif echoing and exp is not None and exp.is_from(series, body):
            if self._echo is None:
                self._emit(out, Garbled(raw=line, is_reply=True))  # the echo came back changed
            else:
                echo = self._echo
                self._emit(
                    out, DataReply(raw=echo + line, is_reply=True, body=body, data=from_wire(rest))
                )
        else:
            self._emit(out, program_output(line, series, body, from_wire(rest)))
