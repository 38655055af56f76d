"""Reading a controller's framing back (§10 EE, EL, ER, SUM), and SUM1 at connect.

Used when a reply showed a framing the gateway did not expect (``framing_track`` hints), after
a lost reply to a framing switch, after ``DL``, and at the first contact after the link came up
when the ``sum_at_connect`` option is on.

The four queries are read raw (``Link.probe``), because their replies are what is in doubt:
``SUM`` first, sent without a checksum; a controller with SUM1 answers such a frame '?' (§10
SUM: a bad command checksum), and is asked again with one. The others are then sent in the
framing found. Query replies do not depend on EL or ER (§10 EL: "query replies unchanged").
"""

from __future__ import annotations

from gateway.bus.exchange import LineExchange
from gateway.protocol import commands
from gateway.protocol.command_replies import ProbeReading, probe_complete, read_probe
from gateway.protocol.framing import Framing, encode_command
from gateway.protocol.models import Command

__all__ = ["detect_framing", "ensure_framing"]


async def _probe(
    core: LineExchange, body: str, command: Command, *, checksum: bool
) -> ProbeReading:
    series = core.config.series_of(body)
    frame = encode_command(body, command.wire(), series=series, framing=Framing(checksum=checksum))
    raw = await core.link.probe(
        body,
        frame,
        reply_len=len(frame) + 7,  # echo + mark B# digit [checksum] CR: the longest form
        complete=lambda got: probe_complete(got, frame),
    )
    core.counters.exchanges += 1
    reading = read_probe(raw, body, series, frame)
    if reading.value is not None:
        core.publish_reply(body, command, reading.value, None)
    return reading


async def _read(core: LineExchange, body: str, command: Command, *, checksum: bool) -> ProbeReading:
    """One probe, with the '?' retries of §9-2."""
    reading = ProbeReading(None)
    for _ in range(1 + core.config.nak_retries):
        reading = await _probe(core, body, command, checksum=checksum)
        if reading.value is not None:
            return reading
        core.counters.retries += 1
    return reading


async def detect_framing(core: LineExchange, body: str) -> Framing | None:
    """Read EE, EL, ER and SUM of ``body``; the framing, or None when it did not answer."""
    sum_query = commands.checksum()
    sum_reading = await _probe(core, body, sum_query, checksum=False)
    if sum_reading.not_accepted:
        # '?' to a frame without a checksum: SUM1 (or noise). Ask again with a checksum.
        sum_reading = await _read(core, body, sum_query, checksum=True)
        if sum_reading.value is None:
            sum_reading = await _read(core, body, sum_query, checksum=False)
    elif sum_reading.value is None:
        sum_reading = await _read(core, body, sum_query, checksum=False)
    if sum_reading.value is None:
        return None
    summed = sum_reading.value == 1
    on: list[bool] = []
    for query in (commands.echo_back(), commands.cr_after_ack(), commands.error_mark()):
        reading = await _read(core, body, query, checksum=summed)
        if reading.value is None:
            return None
        on.append(reading.value == 1)
    echo, cr_after_ack, error_mark = on
    if echo and summed:
        return None  # the device refuses that pair (§10 EE, SUM): the readings are wrong
    return Framing(echo=echo, cr_after_ack=cr_after_ack, error_mark=error_mark, checksum=summed)


async def ensure_framing(core: LineExchange, body: str) -> None:
    """Before a transaction's command: settle a doubted framing, and SUM1 at connect."""
    tracker = core.framing
    why = tracker.suspicion(body)
    first_contact = (
        core.config.sum_at_connect
        and not tracker.confirmed(body)
        and body not in core.detect_failed
    )
    if why is None and not first_contact:
        return
    found = await detect_framing(core, body)
    tracker.clear_suspicion(body)
    if found is None:
        core.detect_failed.add(body)
        return
    core.set_framing(body, found, detected=True)
    if core.config.sum_at_connect and not found.checksum:
        if found.echo:  # SUM1 is refused while EE1 is on (§10 SUM)
            await core.send(body, commands.set_echo_back(False))
        if not core.framing.get(body).echo:
            await core.send(body, commands.set_checksum(True))
