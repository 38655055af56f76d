"""Program upload (§10 I, §11-3): ``I``, then the program text ended by CR, in one transaction.

The text goes out raw after the '>' of ``I``, in the pieces ``upload_chunks`` cuts (the device
joins them; the first CR ends the transfer), and is answered '>' (no echo, no checksum:
docs/manual-notes.md, "Program text after I"). ``I`` answered '?' is sent again (§9-2). After a
lost reply the text still goes out: without a '$' it is ignored by every controller that is not
waiting for program text (§9-1), so sending it can do no harm; then ``IR`` reads back what the
controller holds and decides the outcome.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import replace
from typing import Any

from gateway.bus.detect import ensure_framing
from gateway.bus.exchange import LineExchange
from gateway.bus.requests import CommandResult, Outcome, ReplyKind
from gateway.bus.retries import Retries
from gateway.bus.timing import ack_chars
from gateway.protocol import commands
from gateway.protocol.framing import CR, to_wire
from gateway.protocol.models import Command
from gateway.protocol.program import Program, upload_chunks
from gateway.protocol.replies import ReplyValue
from gateway.protocol.reply_parser import Accepted, CommandRejected

__all__ = ["upload"]

Query = Callable[[Command], Awaitable[ReplyValue | None]]


async def upload(
    core: LineExchange, body: str, command: Command, program: Program, query: Query
) -> CommandResult:
    """Send ``I`` and ``program``; the result of the whole upload, reported under ``I``."""
    seen: dict[str, Any] = {}
    retries = Retries(core.config, core.counters)
    attempts = 0
    while True:
        await ensure_framing(core, body)
        sent = await core.send(body, command)
        attempts += 1
        if sent.kind is not ReplyKind.NOT_ACCEPTED or not retries.after_nak():
            break
    seen["i_reply"] = sent.kind
    frame = sent.frame  # I as written; the program text is not a command frame
    if sent.kind in (ReplyKind.NOT_ACCEPTED, ReplyKind.REJECTED):
        return CommandResult(
            command, sent.kind, Outcome.NOT_DONE, attempts=attempts, seen=seen, note=sent.note,
            frame=frame,
        )  # fmt: skip
    text_kind = await _send_text(core, body, program)
    seen["text_reply"] = text_kind
    if text_kind is ReplyKind.ACCEPTED:
        return CommandResult(
            command, sent.kind, Outcome.DONE, attempts=attempts, late=sent.late, seen=seen,
            frame=frame,
        )  # fmt: skip
    if text_kind is ReplyKind.REJECTED:
        return CommandResult(
            command, text_kind, Outcome.NOT_DONE, attempts=attempts, seen=seen, note="refused",
            frame=frame,
        )  # fmt: skip
    core.counters.verifications += 1
    stored = await query(commands.program_text())
    seen["read_back"] = stored
    if stored is None:
        outcome = Outcome.UNKNOWN
    else:
        outcome = Outcome.DONE if stored == program.text() else Outcome.NOT_DONE
    note = "reply lost; read back IR"
    return CommandResult(
        command, text_kind, outcome, attempts=attempts, seen=seen, note=note, frame=frame
    )


async def _send_text(core: LineExchange, body: str, program: Program) -> ReplyKind:
    framing = replace(core.framing.get(body), echo=False)
    pieces = [to_wire(chunk) for chunk in upload_chunks(program, core.config.upload_chunk)]
    before = 0
    for piece in pieces[:-1]:
        core.link.write_raw(body, piece)
        before += len(piece)
    exchange = await core.link.exchange(
        body,
        pieces[-1] + CR,
        has_data=False,
        framing=framing,
        series=core.config.series_of(body),
        reply_len=ack_chars(framing, 0),
        expect_sent=b"",
        sent_before=before,
    )
    core.counters.exchanges += 1
    event = exchange.event
    if isinstance(event, Accepted):
        return ReplyKind.ACCEPTED
    if isinstance(event, CommandRejected):
        return ReplyKind.REJECTED
    core.doubt(body)
    return ReplyKind.TIMEOUT if event is None else ReplyKind.GARBLED
