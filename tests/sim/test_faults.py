"""Injected faults, each as the host notices it: '?', silence, wrong bytes, lateness, resets."""

from __future__ import annotations

import random
from collections.abc import Callable

import pytest

from gateway.sim.clock import RecordKind
from gateway.sim.faults import FaultKind, FaultRule, Faults, garble, uart_noise
from tests.support.sim_wire import Wire

CHAR_9600 = 10 / 9600


def bits_differing(a: bytes, b: bytes) -> int:
    assert len(a) == len(b)
    return sum(bin(x ^ y).count("1") for x, y in zip(a, b, strict=True))


# ---------------------------------------------------------------------------- pure parts


def test_uart_noise_passes_bytes_at_the_same_rate() -> None:
    for rate in (300, 1200, 9600):
        assert uart_noise(b">$10\r", rate, rate) == b">$10\r"


@pytest.mark.parametrize(("sent", "heard"), [(9600, 1200), (1200, 9600), (300, 9600)])
def test_uart_noise_at_another_rate_is_not_the_message(sent: int, heard: int) -> None:
    assert uart_noise(b">$10\r", sent, heard) != b">$10\r"


def test_a_slow_byte_read_fast_is_its_long_start_bit() -> None:
    # At 1200 one bit lasts 8 bits at 9600: the receiver's whole frame fits inside the start
    # bit and bit 0 of the slow byte; '$' = 0x24 has bit 0 = 0, so it reads 0x00.
    assert uart_noise(b"$", 1200, 9600)[0] == 0x00


def test_garble_flips_one_bit_the_same_way_for_the_same_seed() -> None:
    first = garble(b">$105000\r", random.Random(7))
    assert bits_differing(first, b">$105000\r") == 1
    assert garble(b">$105000\r", random.Random(7)) == first
    assert garble(b"", random.Random(7)) == b""


def test_one_shots_are_used_up_and_nak_comes_first() -> None:
    faults = Faults(seed=1)
    faults.add(FaultRule(FaultKind.DROP, shots=1))
    faults.add(FaultRule(FaultKind.NAK, shots=1, body="1"))
    assert faults.draw("2").kind is FaultKind.DROP  # the nak is for body 1 only
    faults.add(FaultRule(FaultKind.DROP, shots=1))
    assert faults.draw("1").kind is FaultKind.NAK
    assert faults.draw("1").kind is FaultKind.DROP
    assert faults.draw("1").kind is None
    assert faults.rules == []


def test_probabilities_follow_the_seed() -> None:
    def run(seed: int) -> list[FaultKind | None]:
        faults = Faults(seed=seed)
        faults.add(FaultRule(FaultKind.GARBLE, probability=0.25))
        return [faults.draw("1").kind for _ in range(400)]

    assert run(3) == run(3)
    assert run(3) != run(4)
    hits = run(3).count(FaultKind.GARBLE)
    assert 60 <= hits <= 140  # 100 expected


def test_rules_refuse_impossible_values() -> None:
    with pytest.raises(ValueError):
        FaultRule(FaultKind.NAK, probability=1.5)
    with pytest.raises(ValueError):
        FaultRule(FaultKind.SLIP, motor=3)


# ---------------------------------------------------------------------------- on the line


def arm(wire: Wire, kind: FaultKind, **fields: object) -> None:
    wire.loop.faults.add(FaultRule(kind, **fields))  # type: ignore[arg-type]


async def test_nak_answers_question_mark_and_does_not_execute(wire: Wire) -> None:
    arm(wire, FaultKind.NAK, shots=1)
    assert await wire.exchange(b"$1OH4000\r") == b"?"  # §9-2: communication abnormal
    assert await wire.exchange(b"$1OH\r") == b">$105000\r"  # OH4000 was not taken
    assert await wire.exchange(b"$19\r") == b">$101\r"  # §10 9 bit 0: communication error


async def test_drop_executes_but_the_reply_is_lost(wire: Wire) -> None:
    arm(wire, FaultKind.DROP, shots=1)
    assert await wire.exchange(b"$1OH4000\r") == b""
    assert wire.records(RecordKind.NONE)[-1].note == "dropped"
    assert await wire.exchange(b"$1OH\r") == b">$104000\r"


async def test_garble_flips_one_bit_of_the_reply(wire: Wire) -> None:
    arm(wire, FaultKind.GARBLE, shots=1)
    garbled = await wire.exchange(b"$1OH\r")
    assert bits_differing(garbled, b">$105000\r") == 1
    assert await wire.exchange(b"$1OH\r") == b">$105000\r"


async def test_late_reply_comes_after_the_extra_delay(wire: Wire) -> None:
    arm(wire, FaultKind.LATE, shots=1, delay=0.25)
    assert await wire.exchange(b"$1\r") == b">$10\r"
    heard = wire.records(RecordKind.HEARD)[-1]
    reply = wire.records(RecordKind.REPLY)[-1]
    assert reply.time - heard.time == pytest.approx(0.25 + 0.001 + 5 * CHAR_9600, abs=1e-9)


async def test_probable_naks_are_repeatable(make_wire: Callable[..., Wire]) -> None:
    def rule() -> FaultRule:
        return FaultRule(FaultKind.NAK, probability=0.3)

    runs = []
    for _ in range(2):
        wire = make_wire(faults=Faults(seed=11, rules=[rule()]))
        runs.append([await wire.exchange(b"$1\r") for _ in range(60)])
    assert runs[0] == runs[1]
    assert set(runs[0]) == {b"?", b">$10\r"}
    assert 6 <= runs[0].count(b"?") <= 35  # 18 expected


async def test_power_fault_resets_ram_after_the_reply(wire: Wire) -> None:
    # Off for 50 simulated seconds (half a real second): the next frame finds it off
    # however late a busy machine sends it.
    arm(wire, FaultKind.POWER, shots=1, hold=50.0)
    assert await wire.exchange(b"$1OH4000\r") == b">"  # the reply still leaves
    assert await wire.exchange(b"$1\r") == b""  # switched off
    await wire.loop.log.wait_for(lambda r: r.kind is RecordKind.POWER and r.note == "on", 0, 5.0)
    assert await wire.exchange(b"$1OH\r") == b">$105000\r"  # RAM lost (§9-1: until power-off)


async def test_ems_fault_stops_with_the_emergency_flag(wire: Wire) -> None:
    arm(wire, FaultKind.EMS, shots=1, hold=0.05)
    assert await wire.exchange(b"$1\r") == b">$10\r"
    assert await wire.exchange(b"$1\r") == b">$14\r"  # §10 "": bit 2 emergency stop


async def test_cut_line_passes_nothing_until_restored(wire: Wire) -> None:
    wire.controls.cut(True)
    mark = wire.loop.log.next_seq
    wire.send(b"$1OH4000\r")
    await wire.loop.log.wait_for(lambda r: r.kind is RecordKind.LOST and r.data == b"\r", mark, 5.0)
    wire.controls.cut(False)
    assert await wire.exchange(b"$1OH\r") == b">$105000\r"  # the frame never arrived


async def test_cut_fault_cuts_the_line_for_a_while(wire: Wire) -> None:
    arm(wire, FaultKind.CUT, shots=1, hold=0.3)
    assert await wire.exchange(b"$1\r") == b">$10\r"
    restored = await wire.loop.log.wait_for(
        lambda r: r.kind is RecordKind.CUT and r.note == "restored", 0, 5.0
    )
    cut = wire.records(RecordKind.CUT)[0]
    assert restored.time - cut.time == pytest.approx(0.3)
    assert await wire.exchange(b"$1\r") == b">$10\r"
