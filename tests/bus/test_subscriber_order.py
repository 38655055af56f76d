"""The state cache is the one home of what a controller does, whoever hears an event first.

The scheduler feeds the cache before any other subscriber (``use_state``), but nothing may
depend on that: here the poller subscribes to the scheduler's events *before* the cache, and
every answer is the one the usual order gives. What is checked is what a user would notice:
frames on the simulated line (its log, in simulated seconds) and the state the cache shows.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable

import pytest

from gateway.bus.poller import PollConfig, Poller, attach
from gateway.bus.requests import Priority
from gateway.bus.scheduler import LoopScheduler
from gateway.bus.state import ErrorKind, StateCache
from gateway.protocol.command_text import parse
from tests.support.poll_rig import LOOP, Rig, close_rigs, start_rig

ORDERS = ("cache first", "cache last")


def _wire(
    scheduler: LoopScheduler, state: StateCache, bodies: str, order: str, **config: float
) -> Poller:
    """A poller on ``scheduler``: as the gateway wires it, or with the cache subscribed after
    the poller (and fed last, not first)."""
    poll = PollConfig(**config)
    if order == "cache first":
        return attach(scheduler, state, list(bodies), poll)
    poller = Poller(
        scheduler,
        state,
        list(bodies),
        loop=scheduler.name,
        config=poll,
        time_scale=scheduler.config.time_scale,
        clock=scheduler.clock,
        publish=scheduler.events.publish,
    )
    scheduler.events.subscribe(poller.handle)
    scheduler.use_state(state, first=False)  # last: the poller hears every event first
    return poller


@pytest.fixture
async def rig() -> AsyncIterator[Callable[..., Rig]]:
    made: list[Rig] = []

    async def make(order: str, bodies: str = "12", scale: float = 5.0, **config: float) -> Rig:
        def wire(scheduler: LoopScheduler, state: StateCache) -> Poller:
            return _wire(scheduler, state, bodies, order, **config)

        return await start_rig(made, bodies, scale, wire)

    yield make  # type: ignore[misc]
    await close_rigs(made)


@pytest.mark.parametrize("order", ORDERS)
async def test_a_move_is_polled_at_once_and_settled_in_either_order(
    rig: Callable[..., Rig], order: str
) -> None:
    # Idle polls once a (simulated) minute: only what the move's events cause is on the line.
    r = await rig(order, "1", idle_period=60.0, sensor_period=60.0)
    await r.identified("1")
    move = [parse("28000"), parse("32")]  # to 8000 on motor 2 (§10 2, §10 3)
    result = await r.scheduler.submit("1", move, priority=Priority.OPERATOR)
    assert result.ok, result
    # Measured from the move's frame on the line, not from when this task heard the result:
    # on a busy host the poller may read the status before the submitter is scheduled again.
    started = r.frames(b"$132\r")[-1].time
    assert r.state.axis(LOOP, "1", 2).moving  # from the '>' on
    # The status read follows the '>' at once (the idle polls are a simulated minute apart) ...
    await r.until(lambda: bool(r.frames(b"$1\r", since=started)), 5.0)
    assert r.frames(b"$1\r", since=started)[0].time - started < 0.5
    # ... the moving motor's position is read while it turns ...
    await r.until(lambda: len(r.frames(b"$162\r", since=started)) >= 3, 10.0)
    # ... and once a status read has seen the end, its final position and sensors.
    await r.until(lambda: not r.state.axis(LOOP, "1", 2).moving, 10.0)
    await r.until(lambda: bool(r.frames(b"$1CLM2\r", since=started)), 5.0)
    await r.until(lambda: r.state.axis(LOOP, "1", 2).position == 8000, 5.0)
    settle = r.frames(b"$1CLM2\r", since=started)[0].time
    # Not one poll refused for the motion (CLM, EE, EL are not usable while moving).
    assert ErrorKind.COMMAND not in r.state.controller(LOOP, "1").latched
    # The settle read came after the motion ended, not before (a refused CLM would be an error).
    assert settle - started >= 8000 / 5000 * 0.9


@pytest.mark.parametrize("order", ORDERS)
async def test_a_controller_off_and_back_in_either_order(
    rig: Callable[..., Rig], order: str
) -> None:
    r = await rig(order, "12", idle_period=0.2, probe_initial=0.4, probe_max=2.0)
    await r.identified("12")
    r.controls.power("2", False)
    await r.until(lambda: r.state.controller(LOOP, "2").online is False)
    assert r.state.axis(LOOP, "2", 1).stale and r.state.controller(LOOP, "1").online
    offline = r.sim.now()
    await r.sim_time(offline + 5.0)
    r.assert_probed_with_backoff("2", offline)
    on = r.sim.now()
    r.controls.power("2", True)
    await r.until(lambda: r.state.controller(LOOP, "2").online is True)
    for frame in (b"$2V\r", b"$294\r", b"$2SUM\r", b"$2EE\r", b"$2EL\r"):
        await r.until(lambda f=frame: bool(r.frames(f, since=on)))  # type: ignore[misc]
    # Back at the idle rate.
    back = r.sim.now()
    await r.sim_time(back + 2.0)
    assert len(r.frames(b"$2\r", since=back)) >= 5


@pytest.mark.parametrize("order", ORDERS)
async def test_a_controller_that_answers_a_client_is_identified_at_once(
    rig: Callable[..., Rig], order: str
) -> None:
    # Offline, probed only every 30 (simulated) seconds: the poller's own probe is far off.
    r = await rig(order, "12", idle_period=0.2, probe_initial=30.0, probe_max=30.0)
    await r.identified("12")
    r.controls.power("2", False)
    await r.until(lambda: r.state.controller(LOOP, "2").online is False)
    r.controls.power("2", True)
    on = r.sim.now()
    # A client reads it: the cache hears it answer, and the poller takes the cache's word.
    result = await r.scheduler.submit("2", [parse("")], priority=Priority.OPERATOR)
    assert result.ok, result
    assert r.state.controller(LOOP, "2").online is True
    await r.until(lambda: bool(r.frames(b"$2V\r", since=on)), 10.0)
    assert r.frames(b"$2V\r", since=on)[0].time - on < 5.0
    # And polled at its idle rate again, not probed.
    await r.until(lambda: len(r.frames(b"$2\r", since=on)) >= 6, 10.0)


@pytest.mark.parametrize("order", ORDERS)
async def test_f_goes_out_only_when_the_selection_differs_in_either_order(
    rig: Callable[..., Rig], order: str
) -> None:
    # The scheduler reads the selection it publishes back from the cache: fed last or first,
    # it knows at once what it has just confirmed.
    r = await rig(order, "1", idle_period=60.0, sensor_period=60.0, condition_period=60.0)
    await r.identified("1")
    mark = r.sim.now()
    for text, motor in (("OH4000", 2), ("OL400", 2), ("OS200", 1), ("OH3000", 1)):
        result = await r.scheduler.submit("1", parse(text), motor=motor)
        assert result.ok, result
    assert len(r.frames(b"$1F2\r", since=mark)) == 1
    assert len(r.frames(b"$1F1\r", since=mark)) == 1
    assert r.frames(b"$1F2\r", since=mark)[0].time < r.frames(b"$1OH4000\r")[0].time
    assert r.frames(b"$1OL400\r")[0].time < r.frames(b"$1F1\r", since=mark)[0].time
    ctl = r.state.controller(LOOP, "1")
    assert (ctl.selected_motor, ctl.selection_confirmed) == (1, True)
    assert r.scheduler.selected_motor("1") == 1
