"""What a running user program puts on the host line (§11-3, §12 /CO, /CC, /O, §10 ER).

Every message is a whole line the controller sends by itself, like ``$B#*``: the loop queues
it on the return line behind any reply already going out, never inside one (docs/manual-notes.md
"A program's output and a reply in progress"). The encoders are the protocol's own, so the
gateway's parser reads exactly these bytes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gateway.protocol.framing import (
    encode_program_error,
    encode_program_message,
    encode_unsolicited,
)

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

__all__ = ["buffer_message", "counter_message", "error_mark", "query_output", "text_message"]


def query_output(ctl: ControllerView, data: str) -> bytes:
    """A query run as ``/cmd``: its normal reply without the '>' (§11-3), ``$B#data`` CR."""
    return encode_unsolicited(ctl.body, data, ctl.framing, series=ctl.series)


def text_message(ctl: ControllerView, text: str) -> bytes:
    """``/CO{text}``: '>' text CR (§12 /CO example ``>123ABC*+-%`` CR)."""
    return encode_program_message(text, ctl.framing)


def counter_message(ctl: ControllerView, counter: int, count: int) -> bytes:
    """``/CC{ct}``: '>' '$' B# CT and five decimal digits, CR (§12 /CC 転送書式)."""
    return encode_program_message(f"{ctl.series.value}{ctl.body}{counter}{count:05d}", ctl.framing)


def buffer_message(ctl: ControllerView, value: int) -> bytes:
    """``/O3{bf}``: '>' '$' B# DU DL CR.

    §12 /O prints no transfer format for PT 3 (the image is missing); only its fields DU DL are
    named. We write it like ``/CC``, the neighbouring command that sends data to the PC
    (docs/manual-notes.md "/O3 output").
    """
    return encode_program_message(f"{ctl.series.value}{ctl.body}{value:02X}", ctl.framing)


def error_mark() -> bytes:
    """The lone '@' of a command error inside a program with ER1 (§10 ER 注意点)."""
    return encode_program_error()
