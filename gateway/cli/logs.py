"""The log of ``rc233-gateway serve``: plain text for a terminal, JSON lines for a collector.

``--log-format json`` writes one JSON object a line to stderr (the journal under systemd)::

    {"time": "2026-11-25T18:40:01.123Z", "level": "WARNING", "logger": "gateway.state",
     "message": "controller main.3 offline: it does not answer", "event":
     "controller_offline", "loop": "main", "controller": "main.3"}

The context a record carries as ``extra`` (``event``, ``loop``, ``controller``, ``axis`` and
the details of the event) becomes top-level keys. Lines of the loop scheduler that carry no
context but start with ``loop <name>`` get their ``loop`` from that name. Levels are
documented in docs/operations.md ("Log lines").
"""

from __future__ import annotations

import json
import logging
import sys
import time
from typing import Any

__all__ = ["CONTEXT_KEYS", "JsonFormatter", "configure_logging"]

#: ``extra`` keys written into a JSON line, in this order, when a record has them.
CONTEXT_KEYS = (
    "event", "loop", "controller", "axis", "down_seconds", "faults", "operation", "client",
)  # fmt: skip
#: The attributes every LogRecord has: anything else a record carries came from ``extra``.
_RECORD_ATTRS = set(vars(logging.makeLogRecord({}))) | {"message", "asctime", "taskName"}
TEXT_FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"


class JsonFormatter(logging.Formatter):
    """One JSON object per record (see the module)."""

    def format(self, record: logging.LogRecord) -> str:
        """The record as one line of JSON."""
        seconds = time.gmtime(record.created)
        stamp = time.strftime("%Y-%m-%dT%H:%M:%S", seconds) + f".{int(record.msecs):03d}Z"
        line: dict[str, Any] = {
            "time": stamp,
            "level": record.levelname,
            "logger": record.name,
            "message": record.getMessage(),
        }
        extra = {k: v for k, v in vars(record).items() if k not in _RECORD_ATTRS}
        for key in CONTEXT_KEYS:
            if key in extra:
                line[key] = extra.pop(key)
        line.update(sorted(extra.items()))
        # The scheduler's own lines ("loop %s down: %s") name their loop first.
        named = isinstance(record.msg, str) and record.msg.startswith("loop %s")
        if "loop" not in line and named and isinstance(record.args, tuple) and record.args:
            line["loop"] = record.args[0]
        if record.exc_info:
            line["exception"] = self.formatException(record.exc_info)
        return json.dumps(line, ensure_ascii=False, default=str)


def configure_logging(fmt: str, *, verbose: bool = False) -> None:
    """Log to stderr as ``fmt`` ("text" or "json"): INFO and up, DEBUG with ``verbose``."""
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(JsonFormatter() if fmt == "json" else logging.Formatter(TEXT_FORMAT))
    root = logging.getLogger()
    for old in list(root.handlers):
        root.removeHandler(old)
    root.addHandler(handler)
    root.setLevel(logging.DEBUG if verbose else logging.INFO)
