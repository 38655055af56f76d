"""Wire times and reply time-outs from the baud rate and the frame lengths (DESIGN invariant 7).

Lengths are the manual's: §15's reply lengths (``""`` 5, ``9`` 6, ``9{bit}`` 5, ``6`` 12,
``V`` 39 characters with CR), §10 EE's echo table and §10 SUM's checksummed replies.
"""

from __future__ import annotations

import pytest

from gateway.bus.timing import Timing, ack_chars, char_time, reply_chars, wire_time
from gateway.protocol.command_text import parse
from gateway.protocol.framing import Framing

PLAIN = Framing()


def test_a_character_is_about_a_millisecond_at_9600() -> None:
    # §3-I: "about 1 ms a character at 9600 bps"; 8N1 is 10 bits (§2)
    assert char_time(9600) == pytest.approx(0.00104, abs=1e-5)
    assert char_time(300) == pytest.approx(0.0333, abs=1e-4)
    assert wire_time(39, 9600) == pytest.approx(0.040625)  # the V reply, 39 characters


@pytest.mark.parametrize(
    ("text", "chars"),
    [("", 5), ("9", 6), ("97", 5), ("6", 12), ("62", 12), ("V", 39), ("OH", 9), ("C", 6)],
)
def test_reply_lengths_are_the_manuals(text: str, chars: int) -> None:
    assert reply_chars(parse(text), PLAIN, len(f"$1{text}\r")) == chars


def test_framing_changes_the_reply_length() -> None:
    ee = parse("EE")
    # §10 EE: with echo, '$1EE' CR '$11' CR is 9 characters; without, '>$10' CR is 5
    assert reply_chars(ee, Framing(echo=True), 5) == 9
    assert reply_chars(ee, PLAIN, 5) == 5
    # §10 SUM: '>$11C4' CR, 7 characters
    assert reply_chars(parse("SUM"), Framing(checksum=True), 6) == 7
    # general replies: '>' ; EL1 '>' CR ; EL1+SUM1 '>3E' CR ; ER1 '>@' ; EE1 the echo
    assert ack_chars(PLAIN, 4) == 1
    assert ack_chars(Framing(cr_after_ack=True), 4) == 2
    assert ack_chars(Framing(cr_after_ack=True, checksum=True), 4) == 4
    assert ack_chars(Framing(error_mark=True), 4) == 2
    assert ack_chars(Framing(echo=True), len(b"$10\r")) == 4
    # IR has no fixed length: its longest (4416 bytes of program, §10 I) is waited for
    assert reply_chars(parse("IR"), PLAIN, 5) == 4 + 4416


def test_time_outs_scale_with_the_baud_rate() -> None:
    fast = Timing(baud=9600, turnaround=0.0)
    slow = Timing(baud=300, turnaround=0.0)
    # '$16' CR (4) + '>$100000300' CR (12): 16 characters
    assert fast.reply_timeout(4, 12) == pytest.approx(16 * 10 / 9600)
    assert slow.reply_timeout(4, 12) == pytest.approx(16 * 10 / 300)
    assert slow.reply_timeout(4, 12) / fast.reply_timeout(4, 12) == pytest.approx(32)
    margin = Timing(baud=9600, turnaround=0.01)
    assert margin.reply_timeout(4, 12) == pytest.approx(16 * 10 / 9600 + 0.01)


def test_device_time_becomes_host_time() -> None:
    timing = Timing(baud=9600, scale=100.0, host_latency=0.005)
    assert timing.real(1.0) == pytest.approx(0.015)  # scaled, plus the host's own latency
    assert timing.scaled(1.0) == pytest.approx(0.01)
    assert timing.quiet() == pytest.approx(3 * 10 / 9600 / 100 + 0.005)
    with pytest.raises(ValueError):
        Timing(baud=0)
