"""Framing per controller (§10 EE, EL, ER, SUM): tracked when set through the gateway, read
back when a reply shows another one, SUM1 at connect on request.

Checksummed frames are compared with the manual's own vectors (§10 SUM: '$16' CR is sent as
'$168B' CR; '>$10' CR comes back as '>$10C3' CR).
"""

from __future__ import annotations

from gateway.bus.events import FramingChanged, UnsolicitedMessage
from gateway.bus.requests import Outcome
from gateway.protocol.command_text import parse
from gateway.protocol.framing import Framing
from gateway.protocol.reply_values import StatusFlags
from gateway.sim.clock import RecordKind
from gateway.sim.faults import FaultKind
from tests.support.bus_rig import Bus, MakeBus

PROBES = ["SUM", "EE", "EL", "ER"]


def set_framing_behind_the_gateways_back(bus: Bus, framing: Framing, body: str = "1") -> None:
    """As if DW had stored it and the controller was powered on again (§10 DW)."""

    def change(now: float) -> None:
        bus.controller(body).settings.shared.framing = framing

    bus.sim.act(change)


def framing_events(bus: Bus) -> list[tuple[Framing, bool]]:
    return [(e.framing, e.detected) for e in bus.events if isinstance(e, FramingChanged)]


async def test_framing_set_through_the_gateway_is_tracked(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    await bus.scheduler.submit("1", parse("EL1"))
    assert (await bus.scheduler.submit("1", parse("OH4000"))).outcome is Outcome.DONE
    await bus.scheduler.submit("1", parse("SUM1"))
    position = await bus.scheduler.submit("1", parse("6"))
    status = await bus.scheduler.submit("1", parse(""))
    assert position.value == 0 and status.value == StatusFlags()
    # §10 SUM: '$16' CR goes out as '$168B' CR, '$1' CR as '$155' CR
    assert bus.frames()[-2:] == [b"$168B\r", b"$155\r"]
    # §10 SUM: '>$10C3' CR is the checked reply to '$1'
    assert bus.records(RecordKind.REPLY)[-1].data == b">$10C3\r"
    assert framing_events(bus) == [
        (Framing(cr_after_ack=True), False),
        (Framing(cr_after_ack=True, checksum=True), False),
    ]
    counters = bus.scheduler.snapshot()
    assert counters.garbled == counters.checksum_errors == counters.timeouts == 0


async def test_a_cr_after_the_ack_is_detected_and_read_back(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    set_framing_behind_the_gateways_back(bus, Framing(cr_after_ack=True))
    await bus.scheduler.submit("1", parse("OH4000"))
    await bus.scheduler.submit("1", parse("OL400"))
    assert bus.texts() == ["OH4000", *PROBES, "OL400"]
    assert framing_events(bus) == [(Framing(cr_after_ack=True), True)]
    assert bus.scheduler.framing("1") == Framing(cr_after_ack=True)


async def test_an_echo_is_detected_and_the_query_sent_again(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    set_framing_behind_the_gateways_back(bus, Framing(echo=True))
    result = await bus.scheduler.submit("1", parse("OH"))
    assert result.value == 5000
    assert bus.texts() == ["OH", *PROBES, "OH"]
    assert framing_events(bus) == [(Framing(echo=True), True)]
    # The data part that followed the unexpected echo is no program output.
    assert not [e for e in bus.events if isinstance(e, UnsolicitedMessage)]


async def test_checksums_the_gateway_did_not_expect_are_detected(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    set_framing_behind_the_gateways_back(bus, Framing(checksum=True))
    result = await bus.scheduler.submit("1", parse("OH"))
    assert result.value == 5000
    # '$1OH' without a checksum is answered '?' (§10 SUM) every time; then the SUM probe is
    # sent again with one: '$'+'1'+'S'+'U'+'M' = 36+49+83+85+77 = 330 = 14Ah -> '4A'.
    frames = bus.frames()
    assert frames[:5] == [b"$1OH\r"] * 4 + [b"$1SUM\r"]
    assert frames[5] == b"$1SUM4A\r"
    assert frames[-1] == b"$1OHEC\r"  # 36+49+79+72 = 236 = ECh
    assert framing_events(bus) == [(Framing(checksum=True), True)]


async def test_sum_at_connect_turns_checksums_on_first(make_bus: MakeBus) -> None:
    bus = await make_bus("1", sum_at_connect=True)
    assert (await bus.query("1", "6")) == 0
    assert bus.texts()[:5] == [*PROBES, "SUM1"]
    assert bus.frames()[-1] == b"$168B\r"  # §10 SUM example
    assert bus.controller().framing.checksum


async def test_a_lost_reply_to_a_framing_switch_is_read_back(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    bus.fault(FaultKind.DROP)
    result = await bus.scheduler.submit("1", parse("ER1"))
    assert result.outcome is Outcome.DONE
    assert bus.texts() == ["ER1", *PROBES]  # never sent again: it changes the framing
    assert bus.scheduler.framing("1") == Framing(error_mark=True)


async def test_an_error_mark_the_gateway_did_not_expect_is_read_back(make_bus: MakeBus) -> None:
    bus = await make_bus("1")
    set_framing_behind_the_gateways_back(bus, Framing(error_mark=True))
    # G is refused by the simulator (no interpreter yet: notes "G before part II"): an error
    await bus.scheduler.submit("1", parse("G"))
    result = await bus.scheduler.submit("1", parse("G"))
    # §10 ER: '>@' CR-less; first read as '>' then a lone '@' (not a program's output)
    assert not [e for e in bus.events if isinstance(e, UnsolicitedMessage)]
    assert bus.texts() == ["G", *PROBES, "G"]
    assert result.outcome is Outcome.NOT_DONE  # '>@' once the framing is known
    assert framing_events(bus) == [(Framing(error_mark=True), True)]
