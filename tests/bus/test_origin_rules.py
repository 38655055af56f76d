"""The origin and counter rules of the state cache, reply by reply (gateway/bus/origin.py).

Hand-made replies in the scheduler's order, decoded with the protocol's reply decoder; the
API tests (tests/api/test_origin_truth.py, test_counter_truth.py) hold the same rules through
the serial path.
"""

from __future__ import annotations

from gateway.bus.state import StateCache
from gateway.bus.state_types import Origin
from gateway.protocol.command_text import parse
from gateway.protocol.replies import decode_reply

LOOP = "L1"


def reply(cache: StateCache, text: str, data: str | None, time: float, motor: int = 1) -> None:
    """Feed the reply ``data`` (None: '>') of body 1 to ``text`` (acting on ``motor``)."""
    command = parse(text)
    value = None if data is None else decode_reply(command.reply_format, data)
    cache.observe(LOOP, "1", command, value, time, motor=motor)


def homed(cache: StateCache, t: float = 0.0) -> None:
    reply(cache, "61", "00000500", t + 0.1)
    reply(cache, "0", None, t + 0.2)  # origin search, motor 1
    reply(cache, "", "1", t + 0.3)  # moving
    reply(cache, "61", "16776722", t + 0.4)  # CCW past 0 during the search: wrapped
    reply(cache, "", "0", t + 0.5)  # stopped, no error: the origin is found
    reply(cache, "61", "00000000", t + 0.6)


def test_a_search_that_ends_without_error_homes_and_a_wrapped_counter_is_negative() -> None:
    cache = StateCache()
    reply(cache, "61", "00000500", 0.1)
    reply(cache, "0", None, 0.2)
    reply(cache, "", "1", 0.3)
    reply(cache, "61", "16776722", 0.4)
    axis = cache.axis(LOOP, "1", 1)
    assert (axis.position, axis.counter, axis.origin) == (-494, 16_776_722, Origin.UNKNOWN)
    reply(cache, "", "0", 0.5)
    reply(cache, "61", "00000000", 0.6)
    axis = cache.axis(LOOP, "1", 1)
    assert (axis.homed, axis.position, axis.counter) == (True, 0, 0)


def test_a_search_ended_by_a_limit_or_a_stop_does_not_home() -> None:
    cache = StateCache()
    reply(cache, "0", None, 0.1)
    reply(cache, "", "2", 0.2)  # stopped with a limit error: no origin
    assert cache.axis(LOOP, "1", 1).origin is Origin.UNKNOWN
    reply(cache, "0", None, 0.3)
    reply(cache, "S", None, 0.4)
    reply(cache, "", "0", 0.5)
    assert cache.axis(LOOP, "1", 1).origin is Origin.UNKNOWN


def test_a_counter_at_zero_by_itself_is_a_reset_and_loses_both_origins() -> None:
    cache = StateCache()
    homed(cache)
    reply(cache, "3", None, 1.0)  # a move to 10,000
    reply(cache, "", "0", 1.5)
    reply(cache, "61", "00010000", 1.6)
    reply(cache, "62", "00000300", 1.7, motor=2)
    reply(cache, "61", "00000000", 1.9)  # nothing moved it: power-on, or a reply bent?
    assert cache.axis(LOOP, "1", 1).homed  # one reading alone is no proof
    reply(cache, "61", "00000000", 2.0)  # again: power-on restarted it
    one, two = cache.axis(LOOP, "1", 1), cache.axis(LOOP, "1", 2)
    assert (one.origin, one.position, one.counter) == (Origin.LOST, 0, 0)
    assert (two.origin, two.position, two.stale) == (Origin.LOST, None, True)
    ctl = cache.controller(LOOP, "1")
    assert ctl.reset_at == 2.0 and ctl.reset_cause is not None and "10000" in ctl.reset_cause


def test_a_counter_at_zero_after_a_move_a_preset_or_a_program_is_no_reset() -> None:
    cache = StateCache()
    homed(cache)
    reply(cache, "61", "00002000", 1.0)
    reply(cache, "1", None, 1.1)  # to the electrical origin
    reply(cache, "", "0", 1.2)
    reply(cache, "61", "00000000", 1.3)
    assert cache.axis(LOOP, "1", 1).homed
    reply(cache, "R5000", None, 2.0)
    reply(cache, "61", "00005000", 2.1)
    reply(cache, "R0", None, 2.2)
    reply(cache, "61", "00000000", 2.3)
    assert cache.axis(LOOP, "1", 1).homed
    reply(cache, "61", "00000700", 3.0)  # (a program moved it: GSS says it runs)
    reply(cache, "GSS", "1", 3.1)
    reply(cache, "61", "00000000", 3.2)
    assert cache.axis(LOOP, "1", 1).homed


def test_a_controller_silent_and_back_is_read_again_and_its_counters_tell() -> None:
    cache = StateCache()
    homed(cache)
    reply(cache, "61", "00004000", 1.0)
    cache.set_online(LOOP, "1", False, 5.0)
    assert not cache.axis(LOOP, "1", 1).position_current  # no check may use it any more
    reply(cache, "", "0", 6.0)  # answering again: silence alone is no proof of a reset
    assert cache.axis(LOOP, "1", 1).homed
    reply(cache, "61", "00000000", 6.1)  # power-on restarted the counters
    reply(cache, "61", "00000000", 6.2)
    ctl = cache.controller(LOOP, "1")
    assert ctl.reset_at == 6.2 and cache.axis(LOOP, "1", 2).origin is Origin.LOST


def test_after_a_reconnect_no_earlier_reading_is_current() -> None:
    cache = StateCache()
    cache.set_link(LOOP, True, 0.0)
    reply(cache, "", "0", 0.5)
    reply(cache, "61", "16776722", 1.0)  # EP0, nothing before it: as read
    assert cache.axis(LOOP, "1", 1).position == 16_776_722
    reply(cache, "61", "00000100", 1.2)  # 200 pulses CW through the wrap
    assert cache.axis(LOOP, "1", 1).position == 16_777_316
    cache.set_link(LOOP, False, 2.0, cause="cut")
    cache.set_link(LOOP, True, 3.0)
    assert not cache.axis(LOOP, "1", 1).position_current
    reply(cache, "", "0", 3.1)
    reply(cache, "61", "00000100", 3.2)  # not followed from before the reconnect
    axis = cache.axis(LOOP, "1", 1)
    assert (axis.position, axis.position_current) == (100, True)


def test_one_reading_of_zero_between_two_others_is_no_reset() -> None:
    cache = StateCache()
    homed(cache)
    reply(cache, "61", "00010000", 1.0)
    reply(cache, "61", "00000000", 1.1)  # '1' -> '0' is one bit: a reply bent on the line
    reply(cache, "61", "00010000", 1.2)
    reply(cache, "61", "00000000", 1.3)
    axis = cache.axis(LOOP, "1", 1)
    assert axis.homed and cache.controller(LOOP, "1").reset_at is None
