"""Headers every answer carries, and which pages outside the API need a token.

Every HTTP answer gets ``X-Content-Type-Options: nosniff`` (a browser never guesses a type
from the bytes), ``Cache-Control: no-store`` (machine state and problems are never served from
a cache; set by a route that says otherwise, it is kept) and frame protection
(``X-Frame-Options: DENY`` and ``Content-Security-Policy: frame-ancestors 'none'``: the docs
page, whose "Try it out" sends authenticated requests, cannot be framed by another site).

``/metrics`` and the API documentation (``/api/v1/docs``, ``/api/v1/openapi.json``) are open
by default (``security.open_metrics``, ``security.open_docs``): a scraper and a developer read
them without a token, and neither shows a secret or changes anything. Set to false, they need
a token of any role; the refusal is a 401 problem with the bearer challenge, and wrong tokens
count towards the address's back-off as on the API (429 while it waits).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from starlette.datastructures import MutableHeaders
from starlette.responses import Response
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from gateway.api.auth_failures import failures_of, throttled_problem
from gateway.api.problems import Problem, problem_response, problem_type
from gateway.api.security import auth_of_scope, bearer_of_headers, principal_of

__all__ = ["SECURITY_HEADERS", "HardeningMiddleware"]

SECURITY_HEADERS = {
    "X-Content-Type-Options": "nosniff",
    "X-Frame-Options": "DENY",
    "Content-Security-Policy": "frame-ancestors 'none'",
}


class HardeningMiddleware:
    """Add ``SECURITY_HEADERS`` and ``Cache-Control: no-store``; ask a token for ``closed``."""

    def __init__(self, app: ASGIApp, closed: Iterable[str] = ()) -> None:
        self.app = app
        self.closed = frozenset(closed)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """The ASGI entry point."""
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_hardened(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                for name, value in SECURITY_HEADERS.items():
                    if name != "Content-Security-Policy":
                        headers[name] = value
                # A page with a policy of its own (the dashboard's) keeps it, framing refused.
                policy = headers.get("content-security-policy")
                if policy is None:
                    headers["Content-Security-Policy"] = SECURITY_HEADERS["Content-Security-Policy"]
                elif "frame-ancestors" not in policy:
                    headers["Content-Security-Policy"] = f"{policy}; frame-ancestors 'none'"
                if "cache-control" not in headers:
                    headers["Cache-Control"] = "no-store"
            await send(message)

        refusal = self._refusal(scope) if scope["path"] in self.closed else None
        if refusal is not None:
            await refusal(scope, receive, send_hardened)
            return
        await self.app(scope, receive, send_hardened)

    @staticmethod
    def _refusal(scope: Scope) -> Response | None:
        """The answer of a closed page to a caller without a known token (None: let in).
        Wrong tokens count towards the address's back-off as on the API
        (``gateway.api.auth_failures``): while it waits, the page answers 429."""
        failures = None if auth_of_scope(scope).no_auth else failures_of(scope)
        client = scope.get("client")
        address = client[0] if client else "unknown"
        what = f"{scope['method']} {scope['path']}"
        state = scope.setdefault("state", {})
        if failures is not None:
            wait = failures.retry_after(address)
            if wait is not None:
                state["auth_failed"] = True  # recorded by AuthFailures, not per request
                failures.throttled(address, what)
                retry = {"Retry-After": str(math.ceil(wait))}
                return problem_response(throttled_problem(wait), headers=retry)
        principal = principal_of(scope)
        if principal is not None:
            if failures is not None:
                failures.succeeded(address)
            return None
        if failures is not None:
            state["auth_failed"] = True
            failures.failed(address, what, guessed=bearer_of_headers(scope) is not None)
        problem = Problem(
            type=problem_type("unauthorized"),
            title="Unauthorized",
            status=401,
            detail="this page needs a bearer token of any role (security.open_* is false)",
            instance=scope["path"],
        )
        challenge = {"WWW-Authenticate": 'Bearer realm="rc233-gateway"'}
        return problem_response(problem, headers=challenge)
