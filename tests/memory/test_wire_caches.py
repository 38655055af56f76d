"""The worker channel's parsed-command caches hold the texts that repeat, not every move's.

Each end of the channel keeps the commands it parsed from their text; a move or a speed
carries its value in its text, so nearly every one is new. Filled far past the bound, the
memory the two caches hold stays where it was, and a text that repeats (a poll's) is still
parsed once."""

from __future__ import annotations

import gc
import pickle
import tracemalloc
from collections.abc import Iterator
from typing import Any

from gateway.engine.wire import TEXT_CACHE_SIZE, Kind, encode
from gateway.protocol.command_text import parse
from gateway.protocol.models import Command


def _across(command: Command) -> Command:
    """``command`` as the far end of the channel gets it."""
    frame = encode((Kind.SUBMIT, 1, "main", "1", [command]))
    message: tuple[Any, ...] = pickle.loads(frame[4:])
    crossed: Command = message[4][0]
    return crossed


def _new_texts(start: int, count: int) -> Iterator[Command]:
    """Speeds and absolute moves each of its own value, as a client's requests send them."""
    for n in range(start, start + count):
        yield parse(f"OH{1000 + n % 5000}") if n % 2 else parse(f"A011{n:07d}")


def _held_after(commands: Iterator[Command]) -> int:
    for command in commands:
        assert _across(command) == command
    gc.collect()
    return tracemalloc.get_traced_memory()[0]


def test_new_texts_past_the_bound_hold_no_more_memory() -> None:
    assert 32 <= TEXT_CACHE_SIZE <= 512  # room for the repeating texts, no more than minutes
    tracing = tracemalloc.is_tracing()
    if not tracing:
        tracemalloc.start()
    try:
        filled = _held_after(_new_texts(0, 2 * TEXT_CACHE_SIZE))
        held = _held_after(_new_texts(2 * TEXT_CACHE_SIZE, 3_000))
    finally:
        if not tracing:
            tracemalloc.stop()
    # An entry of the two caches weighs some 1 KB (the parsed model, its text and key): 3,000
    # more texts kept would be some 3 MB; bounded, the memory stays where it was.
    assert held - filled < 150_000, f"{held - filled} bytes more after 3,000 new texts"


def test_a_repeating_text_stays_parsed_while_new_texts_pass() -> None:
    poll = parse("A009D")
    first = _across(poll)
    for n, command in enumerate(_new_texts(10_000, 4 * TEXT_CACHE_SIZE)):
        _across(command)
        if n % 16 == 0:  # the poller sends its reads far more often than anyone moves
            assert _across(poll) is first  # the one parsed command serves again
    assert _across(poll) is first
