"""The messages between a line worker and its client: length-prefixed pickles of tuples.

Both ends are the same program, started by the same owner and joined by a socketpair that no
one else can open, so pickle's trust model holds; it also carries the bus's own frozen
dataclasses (results, events, changes) without a second schema to keep in step with them.
Measured against the alternatives in docs/performance.md ("The worker channel").

A message is a tuple whose first item names it (``Kind``). Errors cross as plain fields and
are rebuilt as the bus's own exception classes (``encode_error``/``decode_error``), so that
service/ catches on the far side exactly what it catches in one process.
"""

from __future__ import annotations

import asyncio
import copyreg
import functools
import io
import pickle
import struct
from enum import StrEnum
from types import MappingProxyType
from typing import Any

from gateway.bus.requests import BusError, DeadlineExpired, LoopDown, TransactionError
from gateway.errors import GatewayError
from gateway.protocol.command_text import REGISTRY, parse
from gateway.protocol.models import Command, model_name

__all__ = [
    "Channel",
    "Kind",
    "decode_error",
    "encode",
    "encode_error",
    "read_message",
]

_HEADER = struct.Struct("!I")
#: a message longer than this is a broken peer, not a message (a snapshot of 16 loops of 15
#: controllers is well under a megabyte)
MAX_MESSAGE = 64 * 1024 * 1024

Channel = tuple[asyncio.StreamReader, asyncio.StreamWriter]

#: texts each end keeps parsed (``command_of``) and checked (``_parses_back``). The texts that
#: repeat are the poller's and the status reads, a few dozen; a move's or a speed's carries
#: its value, so nearly every one is new. At 4,096 the two caches took the first hour of
#: traffic to fill (some 1 KB an entry: 4 MB a process), growth a soak still saw after its
#: warm-up; at 256 they fill in minutes and hold 0.25 MB, and the repeating texts, used
#: every second, stay in them (least recently used goes first).
TEXT_CACHE_SIZE = 256


def read_only(mapping: dict[Any, Any]) -> MappingProxyType[Any, Any]:
    """A read-only mapping again, on the receiving end (pickle names this function)."""
    return MappingProxyType(mapping)


def _reduce_mapping(mapping: MappingProxyType[Any, Any]) -> tuple[Any, tuple[dict[Any, Any]]]:
    return read_only, (dict(mapping),)


#: how the records' read-only mappings cross (pickle refuses a ``MappingProxyType`` as such)
_REDUCERS = copyreg.dispatch_table.copy()
_REDUCERS[MappingProxyType] = _reduce_mapping


@functools.lru_cache(maxsize=TEXT_CACHE_SIZE)
def command_of(text: str, model: str) -> Command:
    """A command again from its text (pickle names this function): the models are made per
    form at import, so they cross as the text they encode to and are parsed on arrival
    (once a text: the models are frozen, one parsed command serves every message). A text
    that parses as another model than it was sent as is refused, never guessed."""
    command = parse(text)
    if type(command).__name__ != model:
        raise ValueError(f"{text!r} was sent as {model} and parses as {type(command).__name__}")
    return command


@functools.lru_cache(maxsize=TEXT_CACHE_SIZE)
def _parses_back(text: str, model: str) -> bool:
    """True when ``text`` parses as the model ``model`` outside a program (a program's own
    statements, ``/`` waits among them, do not)."""
    try:
        return type(parse(text)).__name__ == model
    except (GatewayError, ValueError):
        return False


def _command_models() -> dict[str, type[Command]]:
    found: dict[str, type[Command]] = {}
    pending = [Command]
    while pending:
        for cls in pending.pop().__subclasses__():
            found[cls.__name__] = cls
            pending.append(cls)
    return found


_MODELS: dict[str, type[Command]] = {}


def model_of(model: str, fields: dict[str, Any]) -> Command:
    """A command that its text does not name alone, from its model's name and fields (pickle
    names this function): the fields are those of a model that was valid when sent."""
    if model not in _MODELS:
        _MODELS.update(_command_models())
    if model not in _MODELS:
        # the models are made when a form is first used: a worker that has parsed no program
        # yet has none of the program statements' (``/J``, ``/D``), the API process had them
        for entry in REGISTRY.entries:
            if model_name(entry.key) == model:
                _MODELS[model] = entry.model
                break
        else:
            raise ValueError(f"{model} is no command form of the manual")
    return _MODELS[model].model_construct(**fields)


class _Pickler(pickle.Pickler):
    dispatch_table = _REDUCERS

    def reducer_override(self, obj: Any) -> Any:
        if isinstance(obj, Command):
            text, model = obj.wire(), type(obj).__name__
            if _parses_back(text, model):
                return command_of, (text, model)
            return model_of, (model, dict(obj))
        return NotImplemented


class Kind(StrEnum):
    """What a message is (its first item)."""

    START = "start"  # client, first: (START, [LoopSpec, ...]) the loops to run
    SUBMIT = "submit"  # client: (SUBMIT, rid, loop, body, commands, priority, motor, deadline)
    STOP = "stop"  # client, stop channel: (STOP, rid, loop, body, command)
    UPLOAD = "upload"  # client: (UPLOAD, rid, loop, body, Program, priority, deadline)
    REOPEN = "reopen"  # client: (REOPEN, loop, baud) the line at another rate, no answer
    POLLING = "polling"  # client: (POLLING, rid, loop, on) start or stop the loop's poller
    RESYNC = "resync"  # client: (RESYNC,) send a snapshot again (a change was missed)
    ACKNOWLEDGE = "ack"  # client: (ACKNOWLEDGE, loop, body, motor, kinds) clear latches
    TRACE = "trace"  # client: (TRACE, loop, all, bodies, hex_mode, clear) the trace's switches
    FOLLOW = "follow"  # client: (FOLLOW, {(loop, body), ...}) whose reply events to relay
    SNAPSHOT = "snapshot"  # worker: (SNAPSHOT, Snapshot, {loop: (LinkState, cause, ...)})
    TRACED = "traced"  # worker: (TRACED, loop, TraceRecord) one record of a traced loop
    LINE = "line"  # worker: (LINE, loop, baud, adapter report) the line as last opened
    CHANGE = "change"  # worker: (CHANGE, Change)
    EVENT = "event"  # worker: (EVENT, loop, BusEvent, LinkState, cause)
    RESULT = "result"  # worker: (RESULT, rid, TransactionResult)
    ERROR = "error"  # worker: (ERROR, rid, encoded error)
    FRESH = "fresh"  # worker: (FRESH, {key: updated}) replies that changed nothing else


def encode(message: tuple[Any, ...]) -> bytes:
    """One message as it goes on a channel."""
    buffer = io.BytesIO()
    buffer.write(b"\0" * _HEADER.size)
    pickler = _Pickler(buffer, protocol=pickle.HIGHEST_PROTOCOL)
    pickler.dump(message)
    frame = buffer.getbuffer()
    _HEADER.pack_into(frame, 0, len(frame) - _HEADER.size)
    return bytes(frame)


async def read_message(reader: asyncio.StreamReader) -> tuple[Any, ...] | None:
    """The next message; None when the peer closed the channel (or went away)."""
    try:
        head = await reader.readexactly(_HEADER.size)
        (size,) = _HEADER.unpack(head)
        if size > MAX_MESSAGE:
            raise ConnectionError(f"a message of {size} bytes: the peer is broken")
        message = pickle.loads(await reader.readexactly(size))
    except (asyncio.IncompleteReadError, ConnectionError):
        return None
    if not isinstance(message, tuple) or not message:
        raise ConnectionError(f"not a message: {message!r}")
    return message


_ERRORS: dict[str, type[BusError]] = {
    cls.__name__: cls for cls in (BusError, LoopDown, DeadlineExpired, TransactionError)
}


def encode_error(exc: BaseException) -> tuple[str, str, dict[str, Any]]:
    """An exception as plain fields: the bus's errors keep their class and attributes; any
    other becomes a ``TransactionError`` naming it."""
    if type(exc).__name__ in _ERRORS and isinstance(exc, BusError):
        return type(exc).__name__, str(exc), dict(vars(exc))
    return "TransactionError", f"{type(exc).__name__}: {exc}", {}


def decode_error(fields: tuple[str, str, dict[str, Any]]) -> BusError:
    """The exception ``encode_error`` described, of the same class, message and attributes."""
    name, text, attributes = fields
    cls = _ERRORS.get(name, TransactionError)
    exc = cls.__new__(cls)
    Exception.__init__(exc, text)
    vars(exc).update(attributes)
    return exc
