"""A ring bounded by count and by bytes: what a long-running gateway keeps of its recent past.

The gateway runs for months. What it keeps in memory of what happened (audit entries, feed
messages for replay, line trace records) is a ring: the newest items, the oldest forgotten
first. A count alone does not bound memory when items vary in size (an audit entry is a
hundred bytes or ten kilobytes, a trace record a frame or a note), so the ring holds at most
``count`` items and at most ``max_bytes`` of them as the caller measures them (``size_of``:
the JSON text of an entry, the bytes of a frame). The newest item always stays, even alone
over ``max_bytes``: a ring never forgets what just happened.

Any layer may use it (like ``gateway.errors``): it imports nothing of the gateway.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

__all__ = ["BoundedRing"]

T = TypeVar("T")


class BoundedRing(Generic[T]):
    """The newest items, at most ``count`` of them and at most ``max_bytes`` together."""

    def __init__(self, count: int, max_bytes: int, size_of: Callable[[T], int]) -> None:
        if count < 1 or max_bytes < 1:
            raise ValueError(f"a ring holds at least one item of one byte, not {count}/{max_bytes}")
        self.count = count
        self.max_bytes = max_bytes
        self._size_of = size_of
        self._items: deque[T] = deque()
        self._sizes: deque[int] = deque()
        self._bytes = 0
        #: items forgotten to stay within the bounds, since start
        self.forgotten = 0

    def append(self, item: T) -> None:
        """Keep ``item`` as the newest; forget the oldest until both bounds hold."""
        size = self._size_of(item)
        self._items.append(item)
        self._sizes.append(size)
        self._bytes += size
        while len(self._items) > self.count or (
            self._bytes > self.max_bytes and len(self._items) > 1
        ):
            self._items.popleft()
            self._bytes -= self._sizes.popleft()
            self.forgotten += 1

    @property
    def nbytes(self) -> int:
        """The items' sizes together, as ``size_of`` measured them."""
        return self._bytes

    def clear(self) -> None:
        """Forget every item."""
        self._items.clear()
        self._sizes.clear()
        self._bytes = 0

    def __len__(self) -> int:
        return len(self._items)

    def __iter__(self) -> Iterator[T]:
        return iter(self._items)

    def __bool__(self) -> bool:
        return bool(self._items)

    def __getitem__(self, index: int) -> T:
        return self._items[index]
