"""The simulator answers every example exchange of the RC-233 manual byte for byte.

The examples live in manual_examples.py, copied by hand from the Japanese manual (chapters 8,
9, 10, 16); nothing here is computed from the simulator's code. Each example runs in a fresh
simulator (the `wire` fixture of conftest.py: an in-process loop, body 1 present, high time
scale). A failure names the manual section and line, so the reading can be checked at the
source.

The data checks at the end run without the simulator: they keep the hand-made frames honest
(frame shape, the body number in replies, checksums against the manual's own sum vectors).
"""

from __future__ import annotations

import re
from collections import Counter

import pytest

from tests.sim.manual_examples import (
    ACK,
    EXAMPLES,
    NEEDS_CONTROL,
    PART_TWO,
    VERSION_REPLY_PATTERN,
    Example,
    Step,
)

ALL_TABLES = EXAMPLES + NEEDS_CONTROL + PART_TWO


def _describe(example: Example, index: int, step: Step) -> str:
    return (
        f"{example.section} (manual line {example.line}), step {index + 1}: sent {step.send!r}"
        f"\n  setup: {example.setup or '-'}\n  note: {example.note or '-'}"
    )


@pytest.mark.parametrize("example", EXAMPLES, ids=[e.ident for e in EXAMPLES])
async def test_manual_example(wire, example: Example) -> None:  # type: ignore[no-untyped-def]
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


async def test_version_reply_has_the_manual_shape(wire) -> None:  # type: ignore[no-untyped-def]
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
