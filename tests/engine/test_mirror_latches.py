"""Latched errors live in the API process's mirror across a worker's death: a new worker's
snapshot and changes (a cache that never saw the error) do not clear them; only a client's
acknowledge does, in the mirror at once and in the worker by a request."""

from __future__ import annotations

from gateway.bus.state import StateCache
from gateway.bus.state_types import Change, ErrorKind
from gateway.engine.mirror import StateMirror


def _worker(loop: str = "a") -> tuple[StateCache, list[Change]]:
    cache = StateCache()
    changes: list[Change] = []
    cache.changes.subscribe(changes.append)
    cache.write_controller(1.0, loop, "1", online=True)
    return cache, changes


def _mirror() -> tuple[StateMirror, list[tuple[object, ...]]]:
    mirror = StateMirror()
    sent: list[tuple[object, ...]] = []
    mirror.route("a", lambda *args: sent.append(args))
    return mirror, sent


def _follow(mirror: StateMirror, source: str, cache: StateCache, changes: list[Change]) -> None:
    mirror.load(source, cache.snapshot())
    start = len(changes)

    def forward(change: Change) -> None:
        assert mirror.apply(source, change)

    cache.changes.subscribe(forward)
    del changes[:start]


def test_a_latch_outlives_its_worker_and_the_next_workers_records() -> None:
    old, changes = _worker()
    mirror, _ = _mirror()
    _follow(mirror, "w", old, changes)
    old.latch(2.0, "a", "1", [ErrorKind.EMERGENCY, ErrorKind.LIMIT], "")
    assert set(mirror.controller("a", "1").latched) == {ErrorKind.EMERGENCY, ErrorKind.LIMIT}
    assert mirror.axis("a", "1", 1).emergency

    mirror.forget("w")  # the worker died
    mirror.hold(["a"])
    new, new_changes = _worker()  # its successor: the controller read again, no error
    new.latch(3.0, "a", "1", [], "")
    new.write_controller(3.0, "a", "1", moving=False)
    _follow(mirror, "w", new, new_changes)
    assert set(mirror.controller("a", "1").latched) == {ErrorKind.EMERGENCY, ErrorKind.LIMIT}
    assert mirror.axis("a", "1", 1).emergency and mirror.axis("a", "1", 2).emergency

    # The new worker latches a command error: its record now has one latch, the mirror three.
    new.latch(4.0, "a", "1", [ErrorKind.COMMAND], "")
    latched = mirror.controller("a", "1").latched
    assert set(latched) == {ErrorKind.EMERGENCY, ErrorKind.LIMIT, ErrorKind.COMMAND}
    assert mirror.axis("a", "1", 1).emergency and mirror.axis("a", "1", 1).command_error
    # a snapshot again (a missed change): the same
    mirror.load("w", new.snapshot())
    assert set(mirror.controller("a", "1").latched) == set(latched)
    assert set(mirror.held("a", "1")) == {ErrorKind.EMERGENCY, ErrorKind.LIMIT}


def test_an_acknowledge_clears_the_held_latch_and_is_sent_to_the_worker() -> None:
    old, changes = _worker()
    mirror, sent = _mirror()
    _follow(mirror, "w", old, changes)
    old.latch(2.0, "a", "1", [ErrorKind.EMERGENCY], "")
    mirror.forget("w")
    mirror.hold(["a"])
    new, new_changes = _worker()
    _follow(mirror, "w", new, new_changes)

    assert mirror.acknowledge("a", "1", 5.0, motor=1) == []  # motor 2 still shows it
    assert not mirror.axis("a", "1", 1).emergency and mirror.axis("a", "1", 2).emergency
    assert mirror.held("a", "1")[ErrorKind.EMERGENCY].axes == frozenset({2})
    assert mirror.acknowledge("a", "1", 6.0) == [ErrorKind.EMERGENCY]
    assert not mirror.controller("a", "1").latched and not mirror.held("a", "1")
    assert not mirror.axis("a", "1", 2).emergency
    assert sent == [("a", "1", 1, None), ("a", "1", None, None)]
    # the worker's own change afterwards does not bring it back
    new.write_controller(7.0, "a", "1", moving=True)
    assert not mirror.controller("a", "1").latched
