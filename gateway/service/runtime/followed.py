"""Which controllers' reply events the line workers relay: those an operation watches.

An operation's end is followed from the controller's replies (``MotionWatch``: its status
while it moves, its position read back after a lost line), and nothing else in the API
process reads a reply (the state crosses as changes). ``FollowedControllers`` keeps, from
the operations' own events, each controller's latest operation state, and tells the workers
the controllers whose latest operation is not over (queued, sent, moving, or unknown and
waiting for its read-back); the others' polls cross as their ``TransactionDone`` alone.

The operation's first event is published before its commands are submitted, so the worker
learns to relay a controller's replies before the move's own transaction reaches it.
"""

from __future__ import annotations

from collections.abc import Callable

from gateway.service.events import EventKind, ServiceEvent, ServiceEvents

__all__ = ["FollowedControllers"]

#: operation states after which nobody reads the controller's replies for it
_OVER = frozenset({"done", "failed"})


class FollowedControllers:
    """Tells ``follow`` the set of (loop, body) whose replies an operation watches."""

    def __init__(
        self, events: ServiceEvents, follow: Callable[[frozenset[tuple[str, str]]], None]
    ) -> None:
        self._follow = follow
        self._latest: dict[tuple[str, str], str] = {}
        self.followed: frozenset[tuple[str, str]] = frozenset()
        self._unsubscribe = events.subscribe(self._on_event)

    def start(self) -> None:
        """Tell the workers the set as it is (none followed before any operation)."""
        self._follow(self.followed)

    def close(self) -> None:
        """Stop listening."""
        self._unsubscribe()

    def _on_event(self, event: ServiceEvent) -> None:
        if event.kind is not EventKind.OPERATION:
            return
        axis, state = event.data.get("axis"), event.data.get("state")
        if not isinstance(axis, str) or not isinstance(state, str):
            return
        loop, body, _ = axis.split(".")  # an axis id: names have no dots
        self._latest[loop, body] = state
        followed = frozenset(key for key, last in self._latest.items() if last not in _OVER)
        if followed != self.followed:
            self.followed = followed
            self._follow(followed)
