"""The simulator answers every example exchange of the RC-233 manual byte for byte.

The examples live in manual_examples.py, copied by hand from the Japanese manual (chapters 8,
9, 10, 16); nothing here is computed from the simulator's code. Each example runs in a fresh
simulator (the `wire` fixture of conftest.py: an in-process loop, body 1 present, high time
scale). A failure names the manual section and line, so the reading can be checked at the
source.

`NEEDS_CONTROL` runs the same way, with the control surface doing what the manual's operator
does by hand (a sensor, EMS, line noise, the power switch, the host's baud rate, another
wiring): `Step.control` words map to `Controls` calls (`_control_actions`), `needs["scene"]`
to a `Scene` (`SCENES`), and a step with nothing to send waits for the controller's own
message (`Wire.message`, on the line log with a timeout).

The data checks at the end run without the simulator: they keep the hand-made frames honest
(frame shape, the body number in replies, checksums against the manual's own sum vectors).
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Callable
from functools import partial

import pytest

from gateway.sim.control import Controls
from gateway.sim.scene import ALL_SENSORS, AxisScene, EzWiring, Scene, SensorName
from tests.support.manual_examples import (
    ACK,
    EXAMPLES,
    NEEDS_CONTROL,
    VERSION_REPLY_PATTERN,
    Example,
    Step,
)
from tests.support.sim_wire import Wire

ALL_TABLES = EXAMPLES + NEEDS_CONTROL


def _describe(example: Example, index: int, step: Step) -> str:
    return (
        f"{example.section} (manual line {example.line}), step {index + 1}: sent {step.send!r}"
        f"\n  setup: {example.setup or '-'}\n  note: {example.note or '-'}"
    )


@pytest.mark.parametrize("example", EXAMPLES, ids=[e.ident for e in EXAMPLES])
async def test_manual_example(wire: Wire, example: Example) -> None:
    if example.bodies != "1":
        wire.fresh(example.bodies)
    for index, step in enumerate(example.steps):
        reply = await wire.exchange(step.send)
        if step.reply is not None:
            assert reply == step.reply, (
                f"{_describe(example, index, step)}\n"
                f"  manual: {step.reply!r}\n  simulator: {reply!r}"
            )
        if step.wait_idle:
            await wire.wait_idle(chr(step.send[1]))


# ---------------------------------------------------------------------------------------------
# Examples that need the control surface.
# ---------------------------------------------------------------------------------------------

SCENES: dict[str, Scene] = {
    # §10 0 注意点: "ORG センサが接続されて無い状態" -- motor 1's ORG input has no sensor.
    "motor 1 ORG not connected": Scene(
        axes={("1", 1): AxisScene(connected=ALL_SENSORS - {SensorName.ORG})}
    ),
    # §10 0Z: the encoder's Z phase is wired to motor 1's EZ input (the default is the dog).
    "motor 1 EZ connected": Scene(axes={("1", 1): AxisScene(ez=EzWiring.Z)}),
}
"""`needs["scene"]` of the tables -> the scene the example runs in."""

Action = Callable[[Controls], object]

_FORCE = re.compile(r"force ([12]):(cw_limit|ccw_limit|org|ez)=(on|off)")
_BAUD = re.compile(r"loop baud (\d+)")
_INPUTS = re.compile(r"inputs ([0-7](?:,[0-7])*) on")


def _control_actions(control: str, body: str) -> list[Action]:
    """The `Controls` calls a `Step.control` text stands for (manual_examples.py docstring).

    Raises ValueError on a word it does not know, so that a typing mistake in the data cannot
    silently become "do nothing".
    """
    actions: list[Action] = []
    for word in filter(None, (w.strip() for w in control.split(";"))):
        if match := _FORCE.fullmatch(word):
            on = match[3] == "on"
            actions.append(
                partial(Controls.sensor, body=body, motor=int(match[1]), sensor=match[2], on=on)
            )
        elif word == "ems press":
            actions.append(partial(Controls.ems, body=body, pressed=True))
        elif word == "noise":
            # The next frame for `body` is heard as noise: '?' and 9 bit 0 (§9-2 参考).
            actions.append(partial(Controls.fault, kind="nak", body=body))
        elif word == "power_cycle":
            actions.append(partial(Controls.power_cycle, body=body))
        elif match := _BAUD.fullmatch(word):
            actions.append(partial(Controls.baud, baud=int(match[1])))
        elif match := _INPUTS.fullmatch(word):
            for bit in map(int, match[1].split(",")):
                actions.append(partial(Controls.input, body=body, bit=bit, on=True))
        else:
            raise ValueError(f"unknown control word {word!r}")
    return actions


async def _run_step(wire: Wire, example: Example, index: int, step: Step) -> None:
    """Take the step's control actions, then send its frame (or wait for a message)."""
    body = example.bodies[:1] or "1"
    for action in _control_actions(step.control, body):
        action(wire.controls)  # synchronous on the loop: in effect before the next byte
    if step.send:
        reply = await wire.exchange(step.send)
    else:
        reply = await wire.message()  # the controller speaks by itself ($B#*, ...)
    if step.reply is not None:
        assert reply == step.reply, (
            f"{_describe(example, index, step)}\n  control: {step.control or '-'}\n"
            f"  manual: {step.reply!r}\n  simulator: {reply!r}"
        )
    if step.wait_idle:
        await wire.wait_idle(chr(step.send[1]))


@pytest.mark.parametrize("example", NEEDS_CONTROL, ids=[e.ident for e in NEEDS_CONTROL])
async def test_manual_example_with_controls(wire: Wire, example: Example) -> None:
    scene = example.needs.get("scene")
    if scene is not None:
        wire.fresh(example.bodies or "1", scene=SCENES[scene])
    elif example.bodies not in ("", "1"):
        wire.fresh(example.bodies)
    for index, step in enumerate(example.steps):
        await _run_step(wire, example, index, step)
    # The manual prints every message the controller sends by itself in these exchanges.
    assert wire.messages == [], f"{example.ident}: messages the manual does not print"


async def test_version_reply_has_the_manual_shape(wire: Wire) -> None:
    # §10 V (line 6870): ">$B#RC-233 Ver x.xx by RORZE (xx-xx-xx)" CR; §15: 39 characters.
    reply = await wire.exchange(b"$1V\r")
    assert re.fullmatch(VERSION_REPLY_PATTERN, reply), reply
    assert len(reply) == 39


# ---------------------------------------------------------------------------------------------
# Data checks (no simulator needed).
# ---------------------------------------------------------------------------------------------


def _sum(body: bytes) -> bytes:
    """§10 SUM: low byte of the ASCII sum, two upper-case hex digits."""
    return b"%02X" % (sum(body) & 0xFF)


def test_checksum_rule_reproduces_the_manuals_vectors() -> None:
    # §10 SUM send table (lines 6738-6740), reply table (6772-6774), query (6709).
    assert _sum(b"$1") == b"55"
    assert _sum(b"$16") == b"8B"
    assert _sum(b"$1A01300") == b"8A"
    assert _sum(b">$10") == b"C3"
    assert _sum(b">$108") == b"FB"
    assert _sum(b">$11") == b"C4"
    assert _sum(b">$10") != b"C5"  # the manual's example of a corrupted reply


def test_ids_are_unique() -> None:
    counts = Counter(e.ident for e in ALL_TABLES)
    assert [i for i, n in counts.items() if n > 1] == []


@pytest.mark.parametrize("example", ALL_TABLES, ids=[e.ident for e in ALL_TABLES])
def test_frames_are_well_formed(example: Example) -> None:
    assert example.steps
    for step in example.steps:
        if step.send == b"":  # NEEDS_CONTROL: wait for an unsolicited message
            assert example in NEEDS_CONTROL
            continue
        assert step.send.isascii()
        assert re.fullmatch(rb"\$[0-9A-E][^\r$]*\r", step.send), step.send


@pytest.mark.parametrize("example", NEEDS_CONTROL, ids=lambda e: e.ident)
def test_control_words_and_scenes_are_known(example: Example) -> None:
    for step in example.steps:
        _control_actions(step.control, "1")
    assert example.needs.get("scene", next(iter(SCENES))) in SCENES


def test_control_examples_need_the_control_surface() -> None:
    # Each NEEDS_CONTROL example does something commands alone cannot (else it belongs above).
    for example in NEEDS_CONTROL:
        assert example.needs, example.ident
        assert "scene" in example.needs or any(
            step.control or not step.send for step in example.steps
        ), example.ident


def test_main_table_needs_no_control_surface() -> None:
    for example in EXAMPLES:
        assert not example.needs, example.ident
        for step in example.steps:
            assert step.send and not step.control, example.ident


@pytest.mark.parametrize("example", EXAMPLES, ids=[e.ident for e in EXAMPLES])
def test_query_replies_name_the_asking_body(example: Example) -> None:
    # §9-2 書式 (II): ">" "$" B# data CR, B# = the body that answers.
    for step in example.steps:
        if step.reply is not None and step.reply.startswith(b">$"):
            assert step.reply[2] == step.send[1], (example.ident, step)
            assert step.reply.endswith(b"\r")
        elif step.reply is not None and not step.reply.startswith(step.send):
            # Without echo: a general reply, possibly with @ (ER) or CR (EL), or ? (§9-2).
            assert step.reply in {ACK, b">\r", b">@", b">@\r", b"?", b">3E\r"}, step


def test_checksummed_frames_carry_the_right_sum() -> None:
    # While SUM1 is on, every frame is body + 2 hex digits + CR, and so is every reply that
    # ends with CR (§10 SUM 送信/受信フォーマット). One frame is wrong on purpose (its reply is ?).
    checked = 0
    for example in EXAMPLES:
        on = False
        for step in example.steps:
            if on:
                body, digits = step.send[:-3], step.send[-3:-1]
                assert (_sum(body) == digits) == (step.reply != b"?"), (example.ident, step)
                if step.reply is not None and step.reply.endswith(b"\r"):
                    assert _sum(step.reply[:-3]) == step.reply[-3:-1], (example.ident, step)
                checked += 1
                if body == b"$1SUM0":
                    on = False
            elif step.send == b"$1SUM1\r":
                on = True
    assert checked >= 10
