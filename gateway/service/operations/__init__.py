"""Operations: a motion from the request to its outcome. ``book.Operations`` starts and
keeps them, ``motion_watch`` follows each on the state cache, ``types`` holds the operation
and its views, ``terms`` the words of a motion request (units, directions, stop modes)."""

from gateway.service.operations.book import Operations

__all__ = ["Operations"]
