"""No secret in any log, trace or audit entry: tokens are replaced before a line is written.

A browser WebSocket carries its token in the query (``?token=...``), which uvicorn prints in
its access and WebSocket lines (``"WebSocket /api/v1/ws?token=..." [accepted]``), and a
client may put one in any query, under an encoded name too (``?tok%65n=``, which the server
decodes to ``token``). ``redact`` replaces the value of every ``token``, ``access_token`` and
``api_key`` query parameter, by its decoded name, and of a ``Bearer`` credential, with
``***``; ``install_log_redaction`` does it to every log record of the process, and takes the
query off uvicorn's WebSocket line altogether.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Callable
from typing import Any
from urllib.parse import unquote_plus

__all__ = ["MASK", "SECRET_NAMES", "install_log_redaction", "redact"]

MASK = "***"
#: query parameter names whose value is a credential, once percent-decoded and in any case:
#: a server decodes ``?tok%65n=`` to ``token`` (the WebSocket takes it), so the log must too
SECRET_NAMES = frozenset({"token", "access_token", "api_key"})

_QUERY_PARAM = re.compile(r"(^|[?&;\s\"'])([A-Za-z0-9_.~%+-]+)=([^&\s\"'#]*)")
_BEARER = re.compile(r"(?i)(bearer(?:\s|%20|\+)+)[A-Za-z0-9._~+/=%-]+")
#: uvicorn's WebSocket lines (``'%s - "WebSocket %s" [accepted]'``): their path argument
_UVICORN_WS = '"WebSocket %s"'


def _mask_param(match: re.Match[str]) -> str:
    if unquote_plus(match[2]).strip().lower() in SECRET_NAMES:
        return f"{match[1]}{match[2]}={MASK}"
    return match[0]


def redact(text: str) -> str:
    """``text`` with every token value (query parameter, by its decoded name, or bearer
    credential) masked."""
    if "=" not in text and "earer" not in text and "EARER" not in text:
        return text
    return _BEARER.sub(rf"\g<1>{MASK}", _QUERY_PARAM.sub(_mask_param, text))


def _without_query(record: logging.LogRecord) -> None:
    """uvicorn's WebSocket line without the query of its path: a browser's token is there,
    and nothing else of it belongs in a log."""
    args = record.args
    if isinstance(args, tuple) and len(args) >= 2 and isinstance(args[1], str):
        record.args = (args[0], args[1].split("?", 1)[0], *args[2:])


def _clean(record: logging.LogRecord) -> None:
    """Mask secrets in ``record``'s message (formatted with its arguments), in place."""
    if str(record.name).startswith("uvicorn") and _UVICORN_WS in str(record.msg):
        _without_query(record)
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
