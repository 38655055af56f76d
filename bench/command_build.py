"""What building a command model costs: by name (gateway.protocol.commands) or from text (parse).

The scheduler, the poller and the services build a model for every frame they send. ``parse``
fits the text against every form of the catalog; a constructor validates one known form. This
prints microseconds per model for the forms a move and a poll use, each the best of a few
rounds (the machine may be busy: the best round is the one least disturbed).

    .venv/bin/python bench/command_build.py [--rounds 5] [--number 20000]
"""

from __future__ import annotations

import argparse
import timeit
from collections.abc import Callable

from gateway.protocol import Command, PositionFormat, commands, parse

SIGNED = PositionFormat.SIGNED

#: (what, built from text, built by name): the same model both ways
CASES: list[tuple[str, Callable[[], Command], Callable[[], Command]]] = [
    ('status ""', lambda: parse(""), commands.status),
    ("position 61", lambda: parse("61"), lambda: commands.position(1)),
    ("select F2", lambda: parse("F2"), lambda: commands.select_motor(2)),
    (
        "position data 2+1250",
        lambda: parse("2+1250", positions=SIGNED),
        lambda: commands.set_position_data(1250, SIGNED),
    ),
    ("move 3", lambda: parse("3"), commands.move_to_position_data),
    ("High speed OH4000", lambda: parse("OH4000"), lambda: commands.set_speed("OH", 4000)),
]


def main() -> None:
    """Print the cost of each case both ways."""
    args = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    args.add_argument("--rounds", type=int, default=5)
    args.add_argument("--number", type=int, default=20000)
    opts = args.parse_args()
    print(f"{'form':24s} {'parse (us)':>11s} {'by name (us)':>13s} {'ratio':>7s}")
    for what, from_text, by_name in CASES:
        assert from_text() == by_name(), what  # the same model, or the figures mean nothing
        costs = []
        for build in (from_text, by_name):
            best = min(timeit.repeat(build, number=opts.number, repeat=opts.rounds))
            costs.append(best / opts.number * 1e6)
        print(f"{what:24s} {costs[0]:11.1f} {costs[1]:13.1f} {costs[0] / costs[1]:6.0f}x")


if __name__ == "__main__":
    main()
