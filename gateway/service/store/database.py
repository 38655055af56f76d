"""The state directory's SQLite database: what must outlive the process.

``StateStore`` holds one connection, used only from one thread of its own, so nothing on the
event loop ever waits for the disk: ``await store.run(fn)`` runs ``fn(connection)`` there and
returns its result; ``store.post(fn)`` queues it and returns at once (the thread runs the
queued work in order, so a later ``run`` sees every earlier ``post``). The file is in WAL mode
with ``synchronous=FULL``: a transaction that has returned is on disk, a crash at any point
leaves the last committed one.

Tables: ``operations`` (one row per operation, its record as JSON), ``idempotency_keys`` (one
row per key: its request's fingerprint, the operation it started, the response given),
``counters`` (``operation``: the last operation number; ``sparkplug_bdseq``). The schema
version is ``PRAGMA user_version``.

One gateway per state directory: the directory's ``lock`` file is held (``flock``) as long as
the store is open; a second gateway on the same directory is refused at start.
"""

from __future__ import annotations

import asyncio
import contextlib
import fcntl
import logging
import os
import sqlite3
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import IO, TypeVar

from gateway.service.config import ConfigError

__all__ = ["DATABASE_NAME", "SCHEMA_VERSION", "StateStore", "transaction", "write_counter"]

log = logging.getLogger("gateway.service")

T = TypeVar("T")

#: The database's file name in the state directory.
DATABASE_NAME = "state.sqlite3"
SCHEMA_VERSION = 1

_SCHEMA = """
CREATE TABLE IF NOT EXISTS operations (
    id TEXT PRIMARY KEY,
    number INTEGER NOT NULL,
    state TEXT NOT NULL,
    created REAL NOT NULL,
    ended REAL,
    record TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS operations_number ON operations (number);
CREATE TABLE IF NOT EXISTS idempotency_keys (
    ident TEXT PRIMARY KEY,
    fingerprint TEXT NOT NULL,
    created REAL NOT NULL,
    operation TEXT,
    status INTEGER,
    headers TEXT,
    body BLOB
);
CREATE TABLE IF NOT EXISTS counters (
    name TEXT PRIMARY KEY,
    value INTEGER NOT NULL
);
"""


class StateStore:
    """The state database (a file in ``directory``, or in memory when ``directory`` is None:
    then nothing outlives the process, for tests and documents)."""

    def __init__(self, directory: Path | None) -> None:
        self.directory = directory
        self.path = None if directory is None else directory / DATABASE_NAME
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="state-store")
        self._pending: set[Future[object]] = set()
        self._lock: IO[str] | None = None
        self._connection: sqlite3.Connection | None = None
        #: the counters as read at open and set since (read without a hop to the thread)
        self.counters: dict[str, int] = {}
        self._closed = False

    # ------------------------------------------------------------------ life

    @classmethod
    async def open(cls, directory: Path | None) -> StateStore:
        """The store of ``directory`` (created, mode 0700), opened in its own thread."""
        store = cls(directory)
        try:
            await asyncio.get_running_loop().run_in_executor(store._executor, store._open)
        except BaseException:
            store._executor.shutdown(wait=False)
            raise
        return store

    @classmethod
    def memory(cls) -> StateStore:
        """A store in memory, opened now (nothing to wait for: no file)."""
        store = cls(None)
        store._executor.submit(store._open).result()
        return store

    def _open(self) -> None:
        if self.directory is not None:
            try:
                self.directory.mkdir(mode=0o700, parents=True, exist_ok=True)
                self._lock = self._take_lock(self.directory)
                self._connection = sqlite3.connect(self.path or ":memory:", isolation_level=None)
                connection = self._connection
                connection.execute("PRAGMA journal_mode=WAL").fetchone()
                connection.execute("PRAGMA synchronous=FULL")
                self._prepare(connection)
            except (OSError, sqlite3.Error) as exc:
                self._close()  # the directory is free again for a later attempt
                where = f"state_dir {self.directory}"
                raise ConfigError(f"{where}: cannot open the state ({exc})") from None
        else:
            connection = sqlite3.connect(":memory:", isolation_level=None)
            self._prepare(connection)
        self._connection = connection
        rows = connection.execute("SELECT name, value FROM counters").fetchall()
        self.counters = {str(name): int(value) for name, value in rows}

    @staticmethod
    def _prepare(connection: sqlite3.Connection) -> None:
        version = connection.execute("PRAGMA user_version").fetchone()[0]
        if version > SCHEMA_VERSION:
            raise sqlite3.DatabaseError(
                f"schema version {version} is newer than this gateway's ({SCHEMA_VERSION})"
            )
        connection.executescript(_SCHEMA)
        connection.execute(f"PRAGMA user_version={SCHEMA_VERSION}")

    @staticmethod
    def _take_lock(directory: Path) -> IO[str]:
        lock = (directory / "lock").open("a+", encoding="ascii")
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.seek(0)
            holder = lock.read().strip() or "?"
            lock.close()
            raise OSError(f"in use by another gateway (pid {holder})") from None
        lock.seek(0)
        lock.truncate()
        lock.write(f"{os.getpid()}\n")
        lock.flush()
        return lock

    async def close(self) -> None:
        """Finish the queued work, then close the database and release the directory."""
        if self._closed:
            return
        self._closed = True
        await self.drain()
        await asyncio.get_running_loop().run_in_executor(self._executor, self._close)
        self._executor.shutdown(wait=False)

    def _close(self) -> None:
        if self._connection is not None:
            self._connection.close()
            self._connection = None
        if self._lock is not None:
            self._lock.close()  # releases the flock
            self._lock = None

    # ------------------------------------------------------------------ work

    async def run(self, work: Callable[[sqlite3.Connection], T]) -> T:
        """``work(connection)`` in the store's thread, after everything queued before it."""
        return await asyncio.get_running_loop().run_in_executor(self._executor, self._call, work)

    def post(self, work: Callable[[sqlite3.Connection], object]) -> None:
        """Queue ``work(connection)``; its failure is logged (nobody waits for it)."""
        if self._closed:
            log.warning("state store closed: a late write is dropped")
            return
        future: Future[object] = self._executor.submit(self._call, work)
        self._pending.add(future)
        future.add_done_callback(self._posted)

    def _posted(self, future: Future[object]) -> None:
        self._pending.discard(future)
        exc = future.exception()
        if exc is not None:
            log.error("state store: a write failed: %s", exc)

    async def drain(self) -> None:
        """Wait until everything queued so far is done."""
        await self.run(lambda _connection: None)

    def _call(self, work: Callable[[sqlite3.Connection], T]) -> T:
        connection = self._connection
        if connection is None:
            raise sqlite3.ProgrammingError("the state store is closed")
        return work(connection)

    # ------------------------------------------------------------------ counters

    async def set_counter(self, name: str, value: int) -> None:
        """Counter ``name`` is ``value``, on disk when this returns."""
        self.counters[name] = value
        await self.run(lambda c: write_counter(c, name, value))


def write_counter(connection: sqlite3.Connection, name: str, value: int) -> None:
    """Set counter ``name`` (inside the caller's transaction, if any)."""
    connection.execute(
        "INSERT INTO counters (name, value) VALUES (?, ?) "
        "ON CONFLICT (name) DO UPDATE SET value = excluded.value",
        (name, value),
    )


@contextlib.contextmanager
def transaction(connection: sqlite3.Connection) -> Iterator[None]:
    """One transaction: all of it is on disk, or none (``BEGIN IMMEDIATE`` ... ``COMMIT``)."""
    connection.execute("BEGIN IMMEDIATE")
    try:
        yield
    except BaseException:
        connection.execute("ROLLBACK")
        raise
    connection.execute("COMMIT")
