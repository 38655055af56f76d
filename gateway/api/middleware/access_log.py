"""The access log: one line a request, cheap on the path that matters, reads.

uvicorn's own access line costs every request a log record (some 25 µs of CPU, an eighth of a
cached read's), and a gateway read by dashboards and MES polls at hundreds of requests a
second would fill the journal with lines that say nothing the metrics do not
(``rc233_http_requests_total``). So ``serve`` turns uvicorn's off (``access_log=False``) and
``HttpMetricsMiddleware`` calls ``log_access``: the same line as uvicorn's, under the logger
``gateway.access`` (uvicorn silences its own when its access log is off), at INFO for
everything that changes something or fails (every method but GET and HEAD, and every status
from 400 on) and at DEBUG (``serve -v``) for reads that succeeded. A level that is off costs
one comparison. Token values are masked like every other record
(``gateway.api.redaction``).
"""

from __future__ import annotations

import logging

from starlette.types import Scope

__all__ = ["access_level", "log_access"]

log = logging.getLogger("gateway.access")

_READS = frozenset({"GET", "HEAD"})


def access_level(method: str, status: int) -> int:
    """INFO for requests that change something or fail, DEBUG for successful reads."""
    return logging.DEBUG if method in _READS and status < 400 else logging.INFO


def log_access(scope: Scope, status: int) -> None:
    """The access line of the request of ``scope``, answered ``status``."""
    method: str = scope["method"]
    # A failed authentication has its own line, one per address a while
    # (gateway.api.auth_failures): a flood of wrong tokens is not a flood of lines.
    failed = scope.get("state", {}).get("auth_failed", False)
    level = logging.DEBUG if failed else access_level(method, status)
    if not log.isEnabledFor(level):
        return
    client = scope.get("client")
    peer = f"{client[0]}:{client[1]}" if client else "-"
    query: bytes = scope.get("query_string", b"")
    target = scope.get("path", "") + ("?" + query.decode("latin-1") if query else "")
    version = scope.get("http_version", "1.1")
    log.log(level, '%s - "%s %s HTTP/%s" %d', peer, method, target, version, status)
