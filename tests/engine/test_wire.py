"""What crosses the worker channel comes out as it went in: commands (a program's own
statements too, which their text alone does not name), read-only records, the bus's errors."""

from __future__ import annotations

import pickle
import subprocess
import sys
from types import MappingProxyType
from typing import Any

from gateway.bus.requests import DeadlineExpired, LoopDown
from gateway.bus.state_types import Change
from gateway.engine.wire import Kind, decode_error, encode, encode_error
from gateway.protocol.command_text import parse
from gateway.protocol.program import parse_program


def _across(message: tuple[Any, ...]) -> tuple[Any, ...]:
    frame = encode(message)
    assert int.from_bytes(frame[:4], "big") == len(frame) - 4
    decoded: tuple[Any, ...] = pickle.loads(frame[4:])
    return decoded


def test_a_program_crosses_whole() -> None:
    program = parse_program("//22000//3//T10//4//?//T10//5//?//END")
    (_, crossed) = _across((Kind.UPLOAD, program))
    assert crossed == program
    assert [type(s.command) for s in crossed.statements] == [
        type(s.command) for s in program.statements
    ]


def test_a_command_and_a_change_cross_equal() -> None:
    change = Change(3, 1.5, "main", "1", 2, MappingProxyType({"position": -5}))
    _, command, crossed = _across((Kind.SUBMIT, parse("OH4000"), change))
    assert command == parse("OH4000") and command.wire() == "OH4000"
    assert crossed == change and isinstance(crossed.values, MappingProxyType)


def test_the_bus_errors_keep_their_class_message_and_fields() -> None:
    down = LoopDown("main", "the cable", retry_after=2.5, in_flight=True)
    again = decode_error(_across((Kind.ERROR, 1, encode_error(down)))[2])
    assert type(again) is LoopDown and str(again) == str(down)
    assert (again.loop, again.cause, again.retry_after, again.in_flight) == (
        "main", "the cable", 2.5, True,
    )  # fmt: skip
    late = DeadlineExpired("main", "1", 0.5, 7)
    assert str(decode_error(encode_error(late))) == str(late)
    other = decode_error(encode_error(KeyError("x")))
    assert "KeyError" in str(other)


def test_a_program_reaches_a_process_that_never_parsed_one() -> None:
    # The statements' models are made on first use: a fresh worker has none of them yet.
    program = parse_program("/D01B/J-1/END")
    frame = encode((Kind.UPLOAD, program))
    received = subprocess.run(
        [sys.executable, "-c", _RECEIVER], input=frame[4:], capture_output=True, check=False
    )
    assert received.returncode == 0, received.stderr.decode()
    assert received.stdout.decode().split() == [s.command.wire() for s in program.statements]


#: a new interpreter that decodes one message from stdin and prints its program's statements
_RECEIVER = """
import pickle, sys
import gateway.engine.wire
_, program = pickle.loads(sys.stdin.buffer.read())
print(" ".join(s.command.wire() for s in program.statements))
"""
