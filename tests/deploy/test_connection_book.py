"""Which connection makes room at the limit (gateway/cli/connection_guard.ConnectionBook)."""

from __future__ import annotations

from dataclasses import dataclass

from gateway.cli.connection_guard import ConnectionBook


@dataclass(eq=False)
class Conn:
    name: str
    closed: bool = False

    def push_out(self) -> None:
        self.closed = True


def test_at_the_limit_the_longest_waiting_idle_connection_makes_room() -> None:
    book = ConnectionBook(max_connections=3, max_per_client=10)
    old, busy, new = Conn("old"), Conn("busy"), Conn("new")
    for conn in (old, busy, new):
        assert book.admit(conn, "10.0.0.9")
        book.mark_waiting(conn)
    book.mark_busy(busy)  # a request in progress: never pushed out
    stop = Conn("stop")
    assert book.admit(stop, "10.0.0.1")
    assert (old.closed, busy.closed, new.closed) == (True, False, False)
    assert book.per_client == {"10.0.0.9": 2, "10.0.0.1": 1} and book.pushed_out == 1
    book.release(old)  # its close arrives later: counted once
    assert len(book.open) == 3 and book.per_client["10.0.0.9"] == 2


def test_with_every_connection_busy_a_new_one_is_refused() -> None:
    book = ConnectionBook(max_connections=2, max_per_client=10)
    for name in ("a", "b"):
        assert book.admit(Conn(name), "10.0.0.9")  # busy: never marked waiting
    assert not book.admit(Conn("c"), "10.0.0.1")
    assert book.refused == 1 and "10.0.0.1" not in book.per_client


def test_an_address_over_its_share_is_refused_and_others_are_not() -> None:
    book = ConnectionBook(max_connections=100, max_per_client=2)
    first = Conn("1")
    assert book.admit(first, "10.0.0.9") and book.admit(Conn("2"), "10.0.0.9")
    assert not book.admit(Conn("3"), "10.0.0.9")
    assert book.admit(Conn("4"), "10.0.0.1")
    book.release(first)
    assert book.admit(Conn("5"), "10.0.0.9")
