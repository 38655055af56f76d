"""The state cache's CPU for what an idle poll brings it: a status reply, a position reply and
the transaction's ``TransactionDone``, none of which changes anything but the time.

It prints one JSON object: microseconds of CPU for the three events (best of ``--rounds``
rounds of ``--polls`` polls). ``PYTHONPATH=<another tree>`` measures another version of the
cache (the figure before a change: ``git archive <rev> | tar -x -C DIR``).

    .venv/bin/python bench/state_cost.py
"""

from __future__ import annotations

import argparse
import json
import time

from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import ReplyObserved, TransactionDone
from gateway.bus.requests import Outcome, Priority
from gateway.bus.state import StateCache
from gateway.protocol.command_text import parse
from gateway.protocol.replies import decode_reply


def polls(cache: StateCache, count: int, start: float) -> float:
    """CPU seconds a poll for ``count`` idle polls of one controller."""
    status, position = parse(""), parse("61")
    stopped = decode_reply(status.reply_format, "0")
    counters = CountersSnapshot()
    began = time.process_time()
    for i in range(count):
        now = start + i * 0.01
        cache.handle(ReplyObserved(loop="L", time=now, body="1", command=status, value=stopped))
        cache.handle(ReplyObserved(loop="L", time=now, body="1", command=position, value=1234))
        done = TransactionDone(
            loop="L", time=now, body="1", commands=(parse(""),), outcome=Outcome.DONE,
            priority=Priority.POLL, duration=0.01, exchanges=1, counters=counters,
        )  # fmt: skip
        cache.handle(done)
    return (time.process_time() - began) / count


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--polls", type=int, default=5000, help="polls a round")
    parser.add_argument("--rounds", type=int, default=5, help="rounds (the best is kept)")
    args = parser.parse_args()
    cache = StateCache()
    polls(cache, 100, 0.0)  # the controller and its axes exist, nothing changes any more
    best = min(polls(cache, args.polls, 1.0 + r * args.polls) for r in range(args.rounds))
    print(json.dumps({"state_cache_us_per_idle_poll": round(best * 1e6, 1), "polls": args.polls}))


if __name__ == "__main__":
    main()
