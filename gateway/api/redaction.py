"""No secret in any log, trace or audit entry: tokens are replaced before a line is written.

A browser WebSocket carries its token in the query (``?token=...``), which uvicorn prints in
its access and WebSocket lines (``"WebSocket /api/v1/ws?token=..." [accepted]``), and a
client may put one in any query. ``redact`` replaces the value of every ``token``,
``access_token`` and ``api_key`` query parameter, and of a ``Bearer`` credential, with
``***``; ``install_log_redaction`` does it to every log record of the process.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Callable
from typing import Any

__all__ = ["MASK", "install_log_redaction", "redact"]

MASK = "***"

_QUERY_SECRET = re.compile(r"(?i)((?:^|[?&;\s\"'])(?:token|access_token|api_key)=)[^&\s\"'#]*")
_BEARER = re.compile(r"(?i)(bearer\s+)[A-Za-z0-9._~+/=-]+")


def redact(text: str) -> str:
    """``text`` with every token value (query parameter or bearer credential) masked."""
    if "=" not in text and "earer" not in text:
        return text
    return _BEARER.sub(rf"\g<1>{MASK}", _QUERY_SECRET.sub(rf"\g<1>{MASK}", text))


def _clean(record: logging.LogRecord) -> None:
    """Mask secrets in ``record``'s message (formatted with its arguments), in place."""
    try:
        message = record.getMessage()
    except Exception:  # arguments that do not format: logging reports that itself
        return
    cleaned = redact(message)
    if cleaned != message:
        record.msg, record.args = cleaned, ()


class _RedactingFactory:
    """A log record factory that masks secrets in every record it makes."""

    def __init__(self, inner: Callable[..., logging.LogRecord]) -> None:
        self.inner = inner

    def __call__(self, *args: Any, **kwargs: Any) -> logging.LogRecord:
        record = self.inner(*args, **kwargs)
        _clean(record)
        return record


def install_log_redaction() -> None:
    """Mask secrets in every log record of the process, whoever logs it (again: no-op).

    A record factory rather than a filter: a filter on a logger misses what its children
    log, one on a handler misses handlers made later (uvicorn makes its own). Records are
    only made for levels that are enabled, so only lines that are written are formatted.
    """
    current = logging.getLogRecordFactory()
    if not isinstance(current, _RedactingFactory):
        logging.setLogRecordFactory(_RedactingFactory(current))
