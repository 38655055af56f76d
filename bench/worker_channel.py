"""What a message between a line worker and the API process costs to encode and decode.

An idle poll of one controller crosses as two bus events (the reply and the transaction's
end); a change of the state cache as one ``Change``; a request's answer as one result. For
each, microseconds of CPU to encode and decode it (best of ``--rounds``), with the channel's
codec (``gateway.engine.wire``: pickle with the records' reducers) and, for the change,
with two codecs of its plain-tuple form: marshal and msgspec's msgpack (a bound on what a
hand-written schema could save: the bus's records carry the protocol's models, which
neither of them encodes as they are).

    .venv/bin/python bench/worker_channel.py
"""

from __future__ import annotations

import argparse
import json
import marshal
import time
from collections.abc import Callable
from types import MappingProxyType
from typing import Any

from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import ReplyObserved, TransactionDone
from gateway.bus.requests import CommandResult, Outcome, Priority, ReplyKind, TransactionResult
from gateway.bus.state_types import Change
from gateway.engine.wire import Kind, encode
from gateway.protocol.command_text import parse
from gateway.protocol.replies import decode_reply


def _cost(work: Callable[[], Any], count: int, rounds: int) -> float:
    """Best CPU microseconds of one ``work()``."""
    best = float("inf")
    for _ in range(rounds):
        began = time.process_time()
        for _ in range(count):
            work()
        best = min(best, (time.process_time() - began) / count)
    return best * 1e6


def _pickled(message: tuple[Any, ...]) -> Callable[[], Any]:
    import pickle

    def both() -> Any:
        return pickle.loads(encode(message)[4:])

    return both


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=20000, help="messages a round")
    parser.add_argument("--rounds", type=int, default=5, help="rounds (the best is kept)")
    args = parser.parse_args()
    status = parse("")
    stopped = decode_reply(status.reply_format, "0")
    reply = ReplyObserved(loop="L", time=1.0, body="1", command=status, value=stopped, motor=1)
    done = TransactionDone(
        loop="L", time=1.0, body="1", commands=(status,), outcome=Outcome.DONE,
        priority=Priority.POLL, duration=0.01, exchanges=1, counters=CountersSnapshot(),
    )  # fmt: skip
    change = Change(7, 1.0, "L", "1", 1, MappingProxyType({"position": 1234, "updated": 1.0}))
    result = TransactionResult(
        "L", "1", (CommandResult(status, ReplyKind.DATA, Outcome.DONE, stopped),), 1.0, 1.01, 1
    )
    plain = (7, 1.0, "L", "1", 1, {"position": 1234, "updated": 1.0})
    figures: dict[str, float] = {
        "poll_events_pickle_us": _cost(
            lambda: (
                _pickled((Kind.EVENT, "L", reply, "up", ""))(),
                _pickled((Kind.EVENT, "L", done, "up", ""))(),
            ),
            args.count,
            args.rounds,
        ),
        "change_pickle_us": _cost(_pickled((Kind.CHANGE, change)), args.count, args.rounds),
        "result_pickle_us": _cost(_pickled((Kind.RESULT, 1, result)), args.count, args.rounds),
        "change_tuple_marshal_us": _cost(
            lambda: marshal.loads(marshal.dumps(plain)), args.count, args.rounds
        ),
    }
    try:
        import msgspec
    except ImportError:
        figures["change_tuple_msgspec_us"] = float("nan")
    else:
        encoder, decoder = msgspec.msgpack.Encoder(), msgspec.msgpack.Decoder()
        figures["change_tuple_msgspec_us"] = _cost(
            lambda: decoder.decode(encoder.encode(plain)), args.count, args.rounds
        )
    figures["change_bytes_pickle"] = len(encode((Kind.CHANGE, change)))
    figures["poll_event_bytes_pickle"] = len(encode((Kind.EVENT, "L", reply, "up", ""))) + len(
        encode((Kind.EVENT, "L", done, "up", ""))
    )
    print(json.dumps({k: round(v, 2) for k, v in figures.items()}))


if __name__ == "__main__":
    main()
