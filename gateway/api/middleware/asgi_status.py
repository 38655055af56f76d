"""The status an ASGI app answered with, for the middlewares that record requests (audit,
metrics): one pass-through, so that they agree on what a request's status was."""

from __future__ import annotations

from collections.abc import Callable

from starlette.types import ASGIApp, Message, Receive, Scope, Send

__all__ = ["call_noting_status"]


async def call_noting_status(
    app: ASGIApp,
    scope: Scope,
    receive: Receive,
    send: Send,
    then: Callable[[int | None], None],
) -> None:
    """Call ``app``, then ``then(status)`` with the status its response started with: 500 when
    it raised before starting one, None when it ended without an answer (the client went
    away). The exception, if any, goes on to the caller after ``then``."""
    status: int | None = None

    async def tee(message: Message) -> None:
        nonlocal status
        if message["type"] == "http.response.start":
            status = int(message["status"])
        await send(message)

    try:
        await app(scope, receive, tee)
    except Exception:
        status = status or 500
        raise
    finally:
        then(status)
