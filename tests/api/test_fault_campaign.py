"""The REST fault campaign: concurrent clients on a line with 5 % '?', 2 % dropped and 1 %
garbled replies, relative moves on both motors of each of three controllers among reads.

Afterwards every axis stands, by the simulator's own counter, exactly where its start and the
moves the gateway reported ``done`` put it (plus those of the ``unknown`` ones that ran, each
counted and explained); no move reported failed moved; every request was answered. The figures
are printed (``pytest -s``) so they can be quoted.
"""

from __future__ import annotations

import asyncio
import contextlib
import random
import time
from collections import Counter
from typing import Any

import httpx

from gateway.service.events import EventKind, ServiceEvent
from gateway.service.operations.types import Operation, OperationState
from gateway.sim.faults import FaultKind, FaultRule, Faults
from tests.support.sim_app import Api, running_app

NOISE = ((FaultKind.NAK, 0.05), (FaultKind.DROP, 0.02), (FaultKind.GARBLE, 0.01))
AXES = [f"sim.{b}.{m}" for b in "123" for m in (1, 2)]
CLIENTS = 8
REQUESTS = 1200
START = 5000


def noisy(seed: int) -> Faults:
    faults = Faults(seed=seed)
    for kind, p in NOISE:
        faults.add(FaultRule(kind, probability=p))
    return faults


async def client(
    api: Api, rng: random.Random, budget: list[int], seen: Counter[str], own: str | None
) -> None:
    """One client: moves (of its ``own`` axis) and reads at random until the shared budget is
    spent."""
    while budget[0] > 0:
        budget[0] -= 1
        axis = rng.choice(AXES)
        roll = rng.random()
        if own is not None and roll < 0.6:
            axis, roll = own, 0.0
        body = axis.split(".")[1]
        request: Any
        if roll < 0.4:
            step = rng.choice((-1, 1)) * rng.randrange(50, 400)
            request = api.client.post(
                f"/axes/{axis}/move",
                params={"wait": "true"},
                json={"position": step, "relative": True, "unit": "pulse"},
            )
            kind = "move"
        elif roll < 0.7:
            request, kind = api.client.get(f"/axes/{axis}"), "axis"
        elif roll < 0.8:
            request, kind = api.client.get(f"/axes/{axis}/speed"), "speed"
        elif roll < 0.9:
            request = api.client.post(
                f"/controllers/sim.{body}/commands",
                params={"motor": rng.choice((1, 2))},
                json={"command": "OL"},
            )
            kind = "command"
        else:
            request, kind = api.client.get(f"/controllers/sim.{body}"), "controller"
        try:
            response: httpx.Response = await request
        except httpx.HTTPError as exc:  # not answered: counted, and the test fails
            seen[f"{kind} unanswered: {exc!r}"] += 1
            continue
        seen[f"{kind} {response.status_code}"] += 1
        busy = api.operations.active("sim", body)
        if kind == "move" and response.status_code == 409 and busy is not None:
            await busy.finished.wait()  # as a client would: wait for the other motor
        assert response.status_code != 500, response.text  # answered, never a defect


def still_moving(api: Api) -> list[str]:
    """The axes the simulator has moving now."""
    moving: list[str] = []

    def look(now: float) -> None:
        for axis in AXES:
            state = api.device(axis.split(".")[1]).snapshot(now)["axes"][axis[-1]]
            if state["moving"]:
                moving.append(axis)

    api.sim.act(look)
    return moving


def subset_sums(steps: list[int]) -> set[int]:
    """Every sum of a subset of ``steps`` (the unknown moves that may have run)."""
    sums = {0}
    for step in steps:
        sums |= {s + step for s in sums}
    return sums


async def test_rest_fault_campaign_reports_every_move_truthfully() -> None:
    async with running_app() as api:
        await api.identified()
        for axis in AXES:  # away from 0: EP0 positions are unsigned (§7-4)
            r = await api.client.post(
                f"/axes/{axis}/move",
                params={"wait": "true"},
                json={"position": START, "unit": "pulse"},
            )
            assert r.json()["state"] == "done", r.text
        starts = {a: api.position(a.split(".")[1], int(a[-1])) for a in AXES}
        # A move reported done has ended on the device: checked the moment it is published.
        early: list[str] = []

        def on_event(event: ServiceEvent) -> None:
            done = event.kind is EventKind.OPERATION and event.data["state"] == "done"
            if done and event.data["axis"] in still_moving(api):
                early.append(event.data["id"])

        api.runtime.events.subscribe(on_event)
        api.sim.faults = noisy(11)
        began = time.monotonic()
        budget, seen = [REQUESTS], Counter[str]()
        rngs = [random.Random(100 + i) for i in range(CLIENTS)]
        owners = [*AXES, None, None]
        await asyncio.gather(
            *(client(api, rng, budget, seen, own) for rng, own in zip(rngs, owners, strict=True))
        )
        ops = [op for op in api.operations.list(limit=10**6) if op.step is not None]
        await api.until(lambda: all(op.final for op in ops))
        # Unknown outcomes are read back once their controller answers again.
        with contextlib.suppress(TimeoutError):
            await api.until(lambda: not api.operations.unresolved(), timeout=10)
        # Ended as the gateway reports it; on the device too (an unknown outcome may still
        # be moving): the final positions are read once every motor has stopped.
        await api.until(lambda: not still_moving(api))
        wall = time.monotonic() - began
        api.sim.faults = Faults()
        moves = [op for op in ops if op.kind == "move"]
        states = Counter(op.state.value for op in moves)
        unknown = [op for op in moves if op.state is OperationState.UNKNOWN]
        failed = [op for op in moves if op.state is OperationState.FAILED]
        print_figures(api, seen, states, unknown + failed, wall)
        assert early == [], f"reported done while the motor still moved: {early}"
        assert sum(seen.values()) == REQUESTS
        assert not [k for k in seen if "unanswered" in k], seen
        assert sum(n for k, n in seen.items() if k.startswith("move")) >= 200
        for axis in AXES:
            done = [op for op in moves if op.axis.id == axis and op.state is OperationState.DONE]
            assert done, f"no move on {axis} was done"
            body, motor = axis.split(".")[1], int(axis[-1])
            final = api.position(body, motor)
            drift = final - starts[axis] - sum(_step(op) for op in done)
            maybe = [_step(op) for op in unknown if op.axis.id == axis]
            suspects = [
                (op.id, op.state.value, op.step, op.position_before, op.position, op.frames)
                for op in ops
                if op.axis.controller_id == f"sim.{body}" and abs(_step(op)) == abs(drift)
            ]
            assert drift in subset_sums(maybe), (axis, drift, maybe, suspects)
        for op in moves:
            if op.state is OperationState.FAILED and op.position is not None:
                assert op.position == op.position_before, op.view()
        assert len(unknown) <= 0.05 * len(moves)
        assert all(op.error is not None and op.error.detail for op in unknown)


def _step(op: Operation) -> int:
    assert op.step is not None
    return op.step


def print_figures(
    api: Api, seen: Counter[str], states: Counter[str], unsure: list[Operation], wall: float
) -> None:
    counters = api.runtime.scheduler("sim").snapshot()
    faults = Counter(r["kind"] for r in api.sim.faults.describe())
    print(
        f"\nREST fault campaign: {sum(seen.values())} requests from {CLIENTS} clients, {wall:.1f} s"
    )
    for key, n in sorted(seen.items()):
        print(f"  {key:<28} {n}")
    print(f"  moves by state: {dict(states)}")
    print(
        f"  line: {counters.exchanges} exchanges, {counters.naks} '?', {counters.timeouts} "
        f"time-outs, {counters.garbled} garbled, {counters.retries} retries, "
        f"{counters.verifications} read-backs {dict(faults)}"
    )
    for op in unsure:  # every move not reported done, with its reason
        reason = op.error.detail if op.error else ""
        print(f"  {op.state.value} {op.id} {op.axis.id} step {op.step}: {reason}")
