"""A controller that comes back without the SUM1 the gateway set (§10 SUM: only DW saves it).

The controller was switched on SUM1 through the gateway, then off and on again: it listens
without a checksum. A controller with SUM off reads the two digits as part of the command
(body 2's status probe ``$256`` is command ``56``: command 5 form II, MT=6, refused with a
command error). What the wire carries meanwhile, and the errors the state shows, are pinned
here (docs/manual-notes.md "Frames after the framing may have changed").
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable

import pytest

from gateway.bus.poller import PollConfig, attach
from gateway.bus.state import ErrorKind, StateCache
from gateway.protocol.command_text import parse
from gateway.protocol.framing import Framing, checksum
from gateway.sim.clock import RecordKind
from gateway.sim.control import Controls
from gateway.sim.loop import SimLoop
from tests.support.bus_rig import MakeBus
from tests.support.poll_rig import LOOP, MakeRig, Rig, poller_rigs
from tests.support.state_waits import until_state


@pytest.fixture
async def rig() -> AsyncIterator[MakeRig]:
    async with poller_rigs(2.0) as make:
        yield make


def summed(frame: bytes) -> bool:
    """``frame`` ends with the checksum of what comes before it (§10 SUM)."""
    return len(frame) >= 5 and frame[-3:-1] == checksum(frame[:-3])


def heard(sim: SimLoop, body: str, since: float) -> list[bytes]:
    """The frames ``body`` heard from simulated time ``since`` on."""
    return [
        rec.data
        for rec in sim.log.since(0)
        if rec.kind is RecordKind.HEARD and rec.body == body and rec.time >= since
    ]


async def test_a_controller_back_from_off_hears_no_checksum_and_shows_no_false_error(
    rig: Callable[..., Rig],
) -> None:
    r = await rig("12", idle_period=0.2, probe_initial=0.4, probe_max=2.0)
    await r.identified("12")
    result = await r.scheduler.submit("2", parse("SUM1"))
    assert result.ok
    await r.until(lambda: r.state.controller(LOOP, "2").framing == Framing(checksum=True))
    await r.until(lambda: bool(r.frames(b"$256\r")))  # its status probe, with the checksum
    r.controls.power("2", False)
    await r.until(lambda: r.state.controller(LOOP, "2").online is False)
    offline = r.sim.now()
    # Off, it may come back with any framing DW stored: probed without a checksum ('$2' CR,
    # which a controller still on SUM1 answers '?', §10 SUM), never '$256' CR.
    await r.until(lambda: len(r.frames(b"$2\r", since=offline)) >= 2)
    on = r.sim.now()
    r.controls.power("2", True)  # SUM1 was not saved with DW: it listens without checksums
    await r.until(lambda: r.state.controller(LOOP, "2").online is True)
    await r.until(lambda: bool(r.frames(b"$2EL\r", since=on)))  # read through again
    assert r.scheduler.framing("2") == Framing()  # assumed: not read back
    # Not one frame to it since it went off carried a checksum.
    assert not [f for f in heard(r.sim, "2", offline) if summed(f)], heard(r.sim, "2", offline)
    # Nothing the gateway sent was refused: the device latched no command error, and the
    # state shows none (a "command_error" here would be the gateway's own frame misread).
    assert ErrorKind.COMMAND not in r.state.controller(LOOP, "2").latched
    status = await r.scheduler.submit("2", parse(""))
    assert status.value is not None and not status.value.command_error


async def test_with_sum_at_connect_a_controller_back_from_off_is_read_then_set_sum1_again(
    make_bus: MakeBus,
) -> None:
    # The loop configured for checksums (``sum_at_connect``): the gateway set SUM1 itself at
    # the first contact; the controller, off and on again, comes back on SUM0 (no DW).
    bus = await make_bus("12", scale=2.0, sum_at_connect=True)
    state = StateCache()
    poller = attach(
        bus.scheduler,
        state,
        ["1", "2"],
        PollConfig(idle_period=0.2, probe_initial=0.4, probe_max=2.0),
    )
    poller.start()
    try:
        await until_state(
            state,
            lambda: state.controller(bus.scheduler.name, "2").framing == Framing(checksum=True),
            20.0,
        )
        await until_state(state, lambda: b"$256\r" in bus.frames("2"), 20.0)
        Controls(bus.sim).power("2", False)
        await until_state(
            state, lambda: state.controller(bus.scheduler.name, "2").online is False, 20.0
        )
        offline = bus.sim.now()
        Controls(bus.sim).power("2", True)
        await until_state(
            state, lambda: state.controller(bus.scheduler.name, "2").online is True, 20.0
        )
        # Read back plain, then SUM1 again (§10 SUM), and only then checksums.
        await until_state(state, lambda: b"$2SUM1\r" in heard(bus.sim, "2", offline), 20.0)
        sent = heard(bus.sim, "2", offline)
        assert not [f for f in sent[: sent.index(b"$2SUM1\r")] if summed(f)], sent
        await until_state(
            state,
            lambda: state.controller(bus.scheduler.name, "2").framing == Framing(checksum=True),
            20.0,
        )
        assert ErrorKind.COMMAND not in state.controller(bus.scheduler.name, "2").latched
        status = await bus.scheduler.submit("2", parse(""))
        assert bus.frames("2")[-1] == b"$256\r"
        assert status.value is not None and not status.value.command_error
    finally:
        await poller.stop()
