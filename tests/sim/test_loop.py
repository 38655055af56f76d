"""The simulated loop as the host sees it: who answers, when, at which baud rate.

Times are checked against the manual's own figure: at 9600 bit/s one character takes about
1 ms (§3-I), exactly 10 bits (8N1, §2) = 1.0417 ms; a reply arrives after the frame and the
reply have crossed the wire plus the controller's turnaround (1 ms by default).
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from gateway.protocol.framing import Framing, Series, encode_command
from gateway.sim.clock import LineLog, RecordKind, Scheduler, SimClock
from gateway.sim.loop import LineBusy, SimLoop
from gateway.sim.serve import SimPort
from tests.support.sim_wire import Wire, make_loop

CHAR_9600 = 10 / 9600  # §3-I: "about 1 msec" per character at 9600 bps
SUM_ON = Framing(checksum=True)


class ManualTime:
    """A real clock the test moves by hand: the loop is driven with ``run_due``."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def hand_driven(bodies: str = "1", **kwargs: object) -> tuple[SimLoop, list[bytes]]:
    """A loop outside any event loop, its clock at 0, and the list the host receives into."""
    loop = make_loop(bodies, clock=SimClock(1.0, time_fn=ManualTime()), **kwargs)  # type: ignore[arg-type]
    received: list[bytes] = []
    loop.attach(received.append)
    return loop, received


def replies(loop: SimLoop) -> list[tuple[float, bytes]]:
    return [(r.time, r.data) for r in loop.log.since(0) if r.kind is RecordKind.REPLY]


# ---------------------------------------------------------------------------- timing


def test_reply_arrives_after_frame_and_reply_wire_time_plus_turnaround() -> None:
    loop, received = hand_driven()
    loop.host_write(b"$1\r")  # §8-1 (III): the communication check
    loop.scheduler.run_due(1.0)
    assert received == [b">$10\r"]
    [(at, _)] = replies(loop)
    # 3 characters out, 5 back, 1 ms turnaround: 9.33 ms
    assert at == pytest.approx((3 + 5) * CHAR_9600 + 0.001, abs=1e-9)
    assert 0.009 < at < 0.0095  # §3-I: "about 1 ms" a character


def test_turnaround_is_configurable() -> None:
    loop, _ = hand_driven(turnaround=0.005)
    loop.host_write(b"$1\r")
    loop.scheduler.run_due(1.0)
    [(at, _)] = replies(loop)
    assert at == pytest.approx(8 * CHAR_9600 + 0.005, abs=1e-9)


def test_frames_written_at_once_are_answered_one_after_the_other() -> None:
    loop, received = hand_driven()
    loop.host_write(b"$1\r$1\r")
    loop.scheduler.run_due(1.0)
    assert received == [b">$10\r", b">$10\r"]
    (first, _), (second, _) = replies(loop)
    assert first == pytest.approx(8 * CHAR_9600 + 0.001, abs=1e-9)
    # the second frame is complete at 6 characters, but the return line is busy until the
    # first reply has arrived: the second reply follows it, 5 characters long
    assert second == pytest.approx(13 * CHAR_9600 + 0.001, abs=1e-9)


def test_nothing_happens_before_its_time() -> None:
    loop, received = hand_driven()
    loop.host_write(b"$1\r")
    loop.scheduler.run_due(8 * CHAR_9600 + 0.001 - 1e-6)
    assert received == []
    loop.scheduler.run_due(8 * CHAR_9600 + 0.001)
    assert received == [b">$10\r"]


async def test_time_scale_speeds_up_the_wire(make_wire: Callable[..., Wire]) -> None:
    # at 300 bit/s (ES2, §10 ES) the same exchange takes 8 x 33.3 ms + 1 ms = 267.7 ms
    expected = 8 * 10 / 300 + 0.001
    for scale in (1.0, 10.0):
        wire = make_wire(scale=scale)
        assert await wire.exchange(b"$1ES2\r") == b">"
        wire.controls.baud(300)
        start = time.monotonic()
        assert await wire.exchange(b"$1\r") == b">$10\r"
        elapsed = time.monotonic() - start
        assert expected / scale * 0.98 <= elapsed < expected / scale + 0.1, scale


# ---------------------------------------------------------------------------- addressing


async def test_only_the_addressed_controller_answers(make_wire: Callable[..., Wire]) -> None:
    wire = make_wire("1,2,E")
    assert await wire.exchange(b"$2\r") == b">$20\r"
    assert await wire.exchange(b"$E\r") == b">$E0\r"
    assert await wire.exchange(b"$1\r") == b">$10\r"


async def test_an_absent_body_gets_no_answer(make_wire: Callable[..., Wire]) -> None:
    wire = make_wire("1,2")
    assert await wire.exchange(b"$3\r") == b""
    [none] = wire.records(RecordKind.NONE)
    assert none.note == "absent"
    assert await wire.exchange(b"$2\r") == b">$20\r"


async def test_hash_series_answers_hash_frames_only(make_wire: Callable[..., Wire]) -> None:
    wire = make_wire("1", series=Series.HASH)
    assert await wire.exchange(b"$1\r") == b""
    assert await wire.exchange(b"#1\r") == b">#10\r"


async def test_one_host_at_a_time(wire: Wire) -> None:
    with pytest.raises(LineBusy):
        SimPort(wire.loop)
    wire.port.close()
    port = SimPort(wire.loop)
    port.write(b"$1\r")
    assert await port.reader.readexactly(5) == b">$10\r"
    port.close()


# ---------------------------------------------------------------------------- baud rates


async def test_a_controller_at_another_baud_hears_noise(wire: Wire) -> None:
    assert await wire.exchange(b"$1ES1\r") == b">"  # the reply still comes at 9600
    assert await wire.exchange(b"$1\r") == b""  # §10 ES: only 1200 works from now on
    assert wire.records(RecordKind.NONE)[-1].note == "other baud"
    wire.controls.baud(1200)
    # the frame heard as noise set the communication error, bit 0 of 9 (§10 9)
    assert await wire.exchange(b"$19\r") == b">$101\r"
    assert await wire.exchange(b"$1ES0\r") == b">"
    wire.controls.baud(9600)
    assert await wire.exchange(b"$1\r") == b">$10\r"


async def test_a_message_sent_at_another_baud_reaches_the_host_as_noise(wire: Wire) -> None:
    # §10 T: '$1T' CR after 50 s (0.5 s of real time at this scale), long enough for the ES
    # below to land first on a busy host (after 0.5 s, 5 ms of real time, a slow host saw the
    # message go out at 9600 before ES1 took effect)
    assert await wire.exchange(b"$1T500\r") == b">"
    assert await wire.exchange(b"$1ES1\r") == b">"  # from now on the controller talks at 1200
    noise = await wire.delivery(RecordKind.LATER)
    assert noise and noise != b"$1T\r"
    assert b"$" not in noise  # not even the start mark survives


async def test_the_baud_rate_survives_a_power_cycle(
    make_wire: Callable[..., Wire], eeprom_dir: Path
) -> None:
    wire = make_wire(eeprom_dir=eeprom_dir)
    assert await wire.exchange(b"$1ES1\r") == b">"
    wire.controls.power_cycle("1")
    assert await wire.exchange(b"$1\r") == b""  # §10 ES: stored in EEPROM, used at power-on
    wire.controls.baud(1200)
    assert await wire.exchange(b"$1ES\r") == b">$11\r"


async def test_inspection_mode_recovers_an_unknown_baud_rate(
    make_wire: Callable[..., Wire], eeprom_dir: Path
) -> None:
    """§10 ES 注意点: host at 9600, switch F, power on, send '/', switch back, power cycle."""
    wire = make_wire(eeprom_dir=eeprom_dir)
    assert await wire.exchange(b"$1ES2\r") == b">"
    assert await wire.exchange(b"$1\r") == b""
    wire.controls.switch("1", "F")
    wire.controls.power_cycle("1")
    wire.send(b"/")
    assert await wire.delivery(RecordKind.ECHO) == b"/"  # §3-III: it returns what it hears
    wire.controls.switch("1", "1")
    wire.controls.power_cycle("1")
    assert await wire.exchange(b"$1\r") == b">$10\r"
    assert await wire.exchange(b"$1ES\r") == b">$10\r"  # factory setting: 9600


async def test_a_frame_for_a_controller_that_is_off_gets_no_answer(wire: Wire) -> None:
    wire.controls.power("1", False)
    assert await wire.exchange(b"$1\r") == b""
    assert wire.records(RecordKind.NONE)[-1].note == "off"
    wire.controls.power("1", True)
    assert await wire.exchange(b"$1\r") == b">$10\r"


async def test_eeprom_dir_keeps_the_controllers_across_restarts(eeprom_dir: Path) -> None:
    first = Wire(make_loop("1", eeprom_dir=eeprom_dir))
    assert await first.exchange(b"$1OH4000\r") == b">"
    assert await first.exchange(b"$1DW\r") == b">"
    assert await first.message() == b"$1*\r"  # §10 DW: written
    first.close()
    second = Wire(make_loop("1", eeprom_dir=eeprom_dir))
    assert await second.exchange(b"$1OH\r") == b">$104000\r"  # §10 DL at power-on
    second.close()
    third = Wire(make_loop("1"))
    assert await third.exchange(b"$1OH\r") == b">$105000\r"  # §16: the factory value
    third.close()


# ---------------------------------------------------------------------------- framing state


async def test_checksums_follow_sum1(wire: Wire) -> None:
    assert await wire.exchange(b"$1SUM1\r") == b">"
    # §10 SUM: '$1' CR is sent as '$155' CR and answered '>$10C3' CR
    assert await wire.exchange(b"$155\r") == b">$10C3\r"
    assert await wire.exchange(b"$156\r") == b"?"  # a wrong checksum
    assert await wire.exchange(encode_command("1", "SUM0", framing=SUM_ON)) == b">"
    assert await wire.exchange(b"$1\r") == b">$10\r"


async def test_program_text_after_i_is_read_as_text(wire: Wire) -> None:
    assert await wire.exchange(b"$1I\r") == b">"
    assert await wire.exchange(b"/END\r", timeout=2.0) == b">"  # §10 I, §11-3
    assert await wire.exchange(b"$1\r") == b">$10\r"  # no command error


async def test_unsolicited_messages_never_split_a_reply(wire: Wire) -> None:
    assert await wire.exchange(b"$1DW\r") == b">"
    polls = 0
    while not wire.messages:
        assert await wire.exchange(b"$1\r") == b">$10\r"
        polls += 1
    # Every poll was answered whole; the message came between replies, never inside one.
    # (How many polls fit in the write time depends on how the real clock ran meanwhile.)
    assert wire.messages == [b"$1*\r"]
    assert polls >= 1


async def test_the_reply_stream_holds_nothing_else(wire: Wire) -> None:
    wire.send(b"$1\r$2\r$1DW\r")
    expected = b">$10\r>"
    data = await wire.port.reader.readexactly(len(expected))
    assert data == expected
    assert await wire.port.reader.readexactly(4) == b"$1*\r"


def test_the_line_log_keeps_the_last_records_and_their_numbers() -> None:
    log = LineLog(size=3)
    for i in range(10):
        log.add(float(i), RecordKind.HEARD, bytes([i]))
    kept = list(log.since(0))
    assert 3 <= len(kept) <= 6
    assert [r.seq for r in kept] == list(range(10 - len(kept), 10))
    assert [r.data for r in log.since(8)] == [b"\x08", b"\x09"]
    assert list(log.since(10)) == []


async def test_a_precise_clock_never_runs_an_action_early_and_keeps_the_order() -> None:
    # SimClock(precise=True) wakes before the due time on purpose (the benchmarks' real
    # character timing); an action must still never run before its simulated time.
    clock = SimClock(1.0, precise=True)
    scheduler = Scheduler(clock)
    ran: list[tuple[int, float, float]] = []
    finished = asyncio.Event()
    start = clock.now()
    for i, delay in enumerate((0.004, 0.001, 0.0025, 0.002)):
        due = start + delay
        scheduler.at(due, lambda i=i, due=due: ran.append((i, due, clock.now())))
    scheduler.at(start + 0.005, finished.set)
    scheduler.kick()
    await asyncio.wait_for(finished.wait(), 5)
    assert [i for i, _, _ in ran] == [1, 3, 2, 0]  # in time order
    assert all(at >= due for _, due, at in ran)  # never early
    scheduler.close()
