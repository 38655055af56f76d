"""Origin searches 0, 0A, 0H, 0R, 0Z, 0Q as step plans.

A search is a generator (``plan``): it yields an action (run somewhere until a sensor condition,
wait for INP, pulse CLR, finish), the ``Axis`` carries it out in simulated time and sends back
an ``Outcome`` (how the step ended, what ORG and EZ read there). The manual does not tell the
device which case it is in when ORG is OFF; like the device, every search first goes CCW and
learns from what it meets (ORG: case "CW of ORG"; the CCW limit: case "CCW of ORG").

After the ORG recognition stop a search steps 5 pulses at a time until ORG reads ON, then runs
the 0S pulses (§10 0X, conventional algorithm, all modes). When a run's sensor condition is met
(ORG recognised 20 ms late, Z pulses sampled every 1 ms ...) is ``watch``'s business. Choices
where the manual is silent: docs/manual-notes.md, "Simulator axis, sensors and origin searches".
"""

from __future__ import annotations

from collections.abc import Generator
from dataclasses import dataclass
from enum import StrEnum

from gateway.sim.scene import Direction

__all__ = [
    "Action",
    "Ending",
    "Finish",
    "Halt",
    "HomingMethod",
    "HomingSetup",
    "Outcome",
    "PulseClr",
    "Run",
    "Sequence",
    "Speed",
    "Until",
    "Wait",
    "WaitInp",
    "plan",
]

#: §10 0X ②-③: after the recognition stop, pulses are output 5 at a time until ORG reads ON.
STEP_PULSES = 5
#: §10 0Z: 5 pulses CCW at the end, after the n-th Z pulse has gone OFF again.
Z_FINAL_PULSES = 5
#: §10 0X (注意): INP is awaited at most 3 s after pulse output stops.
INP_TIMEOUT = 3.0


class HomingMethod(StrEnum):
    """The origin-search commands (§10 0, 0A, 0H, 0R, 0Z, 0Q)."""

    ORIGIN = "0"  # Low speed search 1
    HIGH_IMMEDIATE = "0A"  # High speed, immediate stop at ORG
    HIGH_DECELERATE = "0H"  # High speed, decelerate to Low at ORG
    REVERSE = "0R"  # RC-204A style search 2: final approach CW
    Z_PHASE = "0Z"  # ORG, then the n-th Z phase pulse
    STEP_OUT = "0Q"  # centre the step-out sensor on its dog


@dataclass(frozen=True)
class HomingSetup:
    """Every setting a search reads (§10 0S, 0B, 0Z, 0X, 0Q, E; defaults of §16)."""

    search_pulses: int = 20  # 0S, 1-65,535
    back_factor: int = 2  # 0B, 0-5
    z_count: int = 1  # 0Z n, 1-9
    algorithm: int = 0  # 0X: 0 conventional, 1 new (mode 2 only)
    step_out_pulses: int = 10  # 0Q pd, 1-65,535
    mode: int = 0  # E: 0, 1, 2

    def __post_init__(self) -> None:
        for name, value, lo, hi in (
            ("0S", self.search_pulses, 1, 65_535),
            ("0B", self.back_factor, 0, 5),
            ("0Z", self.z_count, 1, 9),
            ("0X", self.algorithm, 0, 1),
            ("0Q", self.step_out_pulses, 1, 65_535),
            ("E", self.mode, 0, 2),
        ):
            if not lo <= value <= hi:
                raise ValueError(f"{name} {value} outside {lo}-{hi}")

    @property
    def back_pulses(self) -> int:
        """Pulses run past the ORG OFF edge before turning back: 0S × 0B (§10 0, 0B)."""
        return self.search_pulses * self.back_factor


class Until(StrEnum):
    """What ends a run of a search (besides the limit in its direction)."""

    DISTANCE = "distance"  # ``pulses`` pulses done
    ORG_ON = "org_on"  # ORG recognised (6 pulses, 20 ms late)
    ORG_PASSED = "org_passed"  # ORG ON (or ON at the start), then OFF: stop on the first OFF
    Z_PHASE = "z_phase"  # ORG confirmed, then the ``pulses``-th Z pulse confirmed
    EZ_OFF = "ez_off"  # EZ reads OFF
    EZ_WIDTH = "ez_width"  # EZ ON, then OFF again at least ``pulses`` pulses later


class Speed(StrEnum):
    """Low speed (fL, no ramp) or High speed (ramp from fL up to fH)."""

    LOW = "low"
    HIGH = "high"


class Halt(StrEnum):
    """How a run ends once its condition is met."""

    IMMEDIATE = "immediate"  # pulse output stops at once
    TO_LOW = "to_low"  # ramp down to fL; the run ends when fL is reached (0H)


@dataclass(frozen=True)
class Run:
    """Turn in ``direction`` until the condition; ``pulses`` is its number, if it has one."""

    direction: Direction
    until: Until
    pulses: int = 0
    speed: Speed = Speed.LOW
    halt: Halt = Halt.IMMEDIATE


@dataclass(frozen=True)
class WaitInp:
    """Mode 2: wait for INP, at most 3 s after pulse output stopped (§10 0X ③ ⑤)."""


@dataclass(frozen=True)
class Wait:
    """Pause for ``seconds``, moving as far as the status flags go (§10 QJ ①: QJT)."""

    seconds: float


@dataclass(frozen=True)
class PulseClr:
    """Mode 2: the CLR output goes ON for 100 µs (§10 0X, §10 DS ①)."""


@dataclass(frozen=True)
class Finish:
    """The search is over: origin set (``homed``) or an error stop with limit error."""

    homed: bool


Action = Run | WaitInp | Wait | PulseClr | Finish


class Ending(StrEnum):
    """How a step ended."""

    DONE = "done"  # condition met or distance run
    LIMIT = "limit"  # the limit sensor in the direction of travel turned ON
    TIMEOUT = "timeout"  # no INP within 3 s
    STEP_OUT = "step_out"  # a plain motion stopped by step-out detection (§10 Q, QE)


@dataclass(frozen=True)
class Outcome:
    """What the Axis reports after a step: how it ended and what ORG / EZ read where it stands."""

    ending: Ending = Ending.DONE
    org: bool = False
    ez: bool = False
    org_seen: bool = False  # Z_PHASE: ORG had been confirmed before the run ended
    width: int = 0  # EZ_WIDTH: the ON width measured [pulses]


Sequence = Generator[Action, Outcome, None]
_Steps = Generator[Action, Outcome, None]

CW, CCW = Direction.CW, Direction.CCW


def plan(method: HomingMethod, setup: HomingSetup, start: Outcome) -> Sequence:
    """The step plan of ``method``; ``start`` holds the readings where the axis stands."""
    if method is HomingMethod.ORIGIN:
        return _origin(setup, start)
    if method is HomingMethod.HIGH_IMMEDIATE:
        return _high(setup, start, Halt.IMMEDIATE)
    if method is HomingMethod.HIGH_DECELERATE:
        return _high(setup, start, Halt.TO_LOW)
    if method is HomingMethod.REVERSE:
        return _reverse(setup)
    if method is HomingMethod.Z_PHASE:
        return _z_phase(setup, start)
    return _dog(setup)


def _approach(setup: HomingSetup, direction: Direction) -> _Steps:
    """From the ORG recognition stop on (§10 0X ②-⑤), then the origin."""
    servo = setup.mode == 2
    new = servo and setup.algorithm == 1
    if new:
        yield PulseClr()  # 0X1 ②: CLR together with the recognition stop
    while True:
        out = yield Run(direction, Until.DISTANCE, STEP_PULSES)
        if out.ending is Ending.LIMIT:
            yield Finish(False)
            return
        if new:  # 0X1 ③: wait for INP after every 5-pulse step
            out = yield WaitInp()
            if out.ending is Ending.TIMEOUT:
                yield PulseClr()
                yield Finish(False)
                return
        if out.org:
            break
    out = yield Run(direction, Until.DISTANCE, setup.search_pulses)
    if out.ending is Ending.LIMIT:
        yield Finish(False)
        return
    if servo:  # 0X ⑤: INP within 3 s, else CLR and limit error
        out = yield WaitInp()
        if out.ending is Ending.TIMEOUT or not new:
            yield PulseClr()
        if out.ending is Ending.TIMEOUT:
            yield Finish(False)
            return
    yield Finish(True)


def _back_off(setup: HomingSetup) -> _Steps:
    """CW past ORG, 0S × 0B more, then the final CCW approach (§10 0 cases B and C)."""
    out = yield Run(CW, Until.ORG_PASSED)
    if out.ending is not Ending.LIMIT and setup.back_pulses:
        out = yield Run(CW, Until.DISTANCE, setup.back_pulses)
    if out.ending is not Ending.LIMIT:
        out = yield Run(CCW, Until.ORG_ON)
    if out.ending is Ending.LIMIT:
        yield Finish(False)
        return
    yield from _approach(setup, CCW)


def _origin(setup: HomingSetup, start: Outcome) -> _Steps:
    """§10 0: A (CW of ORG) CCW onto ORG; B (on ORG) and C (CCW limit first) back off first."""
    if not start.org:
        out = yield Run(CCW, Until.ORG_ON)
        if out.ending is Ending.DONE:
            yield from _approach(setup, CCW)
            return
    yield from _back_off(setup)


def _high(setup: HomingSetup, start: Outcome, halt: Halt) -> _Steps:
    """§10 0A / 0H: High speed CCW; at ORG (or the CCW limit) back to Low speed, then as 0 B."""
    if not start.org:
        # Either ending continues alike: ORG (stopped or slowed) or the CCW limit (§10 0A, 0H).
        yield Run(CCW, Until.ORG_ON, speed=Speed.HIGH, halt=halt)
    yield from _back_off(setup)


def _reverse(setup: HomingSetup) -> _Steps:
    """§10 0R: CCW past ORG (or to the CCW limit), then the final approach CW."""
    yield Run(CCW, Until.ORG_PASSED)
    out = yield Run(CW, Until.ORG_ON)
    if out.ending is Ending.LIMIT:  # §10 0R 注意点: the CW limit is an error stop
        yield Finish(False)
        return
    yield from _approach(setup, CW)


def _z_phase(setup: HomingSetup, start: Outcome) -> _Steps:
    """§10 0Z: A: CCW to ORG and n Z pulses; B (CCW limit), C (on ORG): back off first."""
    search = Run(CCW, Until.Z_PHASE, setup.z_count)
    out: Outcome | None = None
    if not start.org:
        out = yield search
        if out.ending is Ending.LIMIT:
            if out.org_seen:  # ORG found, then the limit: an error, not case B (our choice)
                yield Finish(False)
                return
            out = None
    if out is None:  # case B (reversed at the CCW limit) or C (started on ORG)
        out = yield Run(CW, Until.ORG_PASSED)
        if out.ending is not Ending.LIMIT and setup.back_pulses:
            out = yield Run(CW, Until.DISTANCE, setup.back_pulses)
        if out.ending is not Ending.LIMIT:
            out = yield search
    if out.ending is not Ending.LIMIT:  # n-th Z: reverse CW until it goes OFF, 5 pulses CCW
        out = yield Run(CW, Until.EZ_OFF)
    if out.ending is not Ending.LIMIT:
        out = yield Run(CCW, Until.DISTANCE, Z_FINAL_PULSES)
    if out.ending is Ending.LIMIT:
        yield Finish(False)
        return
    if setup.mode == 2:
        yield PulseClr()  # §10 DS ①: after the final 5 pulses
    yield Finish(True)


def _dog(setup: HomingSetup) -> _Steps:
    """§10 0Q: to the dog's CCW edge, measure its ON width CW, go back to its centre."""
    out = yield Run(CCW, Until.EZ_OFF)
    if out.ending is not Ending.LIMIT:
        out = yield Run(CW, Until.EZ_WIDTH, setup.step_out_pulses)
    if out.ending is not Ending.LIMIT:
        out = yield Run(CCW, Until.DISTANCE, out.width - out.width // 2)
    yield Finish(out.ending is not Ending.LIMIT)
