"""The table from command forms to the simulator's handlers, and what a handler may return.

A handler is registered for one or more form keys of the catalog (``"OH{hs}"``, ``"OH"``, ...).
It receives the controller, the parsed command model and the simulated time, and returns the
reply value of a query (encoded by the protocol's own ``encode_reply``), or None for a general
command (answered ``>``). It raises ``Refused`` for a command the device ignores with the
command-error flag (§9-1 注意).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

from gateway.protocol.command_text import REGISTRY

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

__all__ = ["HANDLERS", "Handler", "Refused", "handles", "missing_handlers"]


class Refused(Exception):
    """The controller ignores the command and sets the command-error flag (§9-1 注意)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


Handler = Callable[["ControllerView", Any, float], object]
HANDLERS: dict[str, Handler] = {}

_H = TypeVar("_H", bound=Handler)


def handles(*keys: str) -> Callable[[_H], _H]:
    """Register a handler for the form keys ``keys``; a key registered twice is a bug."""
    known = {entry.key for entry in REGISTRY.entries}

    def register(handler: _H) -> _H:
        for key in keys:
            if key not in known:
                raise KeyError(f"{key!r} is not a form of the catalog")
            if key in HANDLERS:
                raise KeyError(f"{key!r} has two handlers")
            HANDLERS[key] = handler
        return handler

    return register


def missing_handlers() -> list[str]:
    """Host forms of the catalog without a handler (a test keeps this empty)."""
    return [
        entry.key
        for entry in REGISTRY.entries
        if not entry.spec.program_only
        and entry.key not in HANDLERS
        # the framing switches change the framing of their own reply (§10 EL) or of the
        # next one (§10 EE, ER, SUM): the controller applies them itself, around the reply
        and not entry.form.switches_framing
    ]
