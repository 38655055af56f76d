"""What an entry may hold: JSON-safe values of bounded size, whatever a client sends.

A request body, an MQTT payload or any other value of an entry whose JSON text is longer than
``VALUE_LIMIT`` bytes is kept as its first ``VALUE_LIMIT`` bytes (as text, ``<key>`` itself),
with ``<key>_truncated: true``, ``<key>_bytes`` (the length of the whole JSON text) and
``<key>_sha256`` (its SHA-256, so a copy kept elsewhere can be matched to the entry). A flood
then costs its sender: one DCMD with 200,000 metrics is one line of about 1 KiB, not 4.8 MiB.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel

__all__ = ["VALUE_LIMIT", "bounded", "plain"]

#: bytes of a value's JSON text kept in an entry
VALUE_LIMIT = 1024
#: keys never cut: the record's own fields
_NEVER_CUT = frozenset({"seq", "prev", "time", "method", "path", "intent", "event"})


def plain(value: Any) -> Any:
    """``value`` made JSON-safe: bytes (wire frames) as Latin-1 text, tuples as lists."""
    if isinstance(value, bytes | bytearray):
        return bytes(value).decode("latin-1")
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple | set | frozenset):
        return [plain(v) for v in value]
    if isinstance(value, BaseModel):
        return value.model_dump(mode="json")
    if value is None or isinstance(value, str | int | float | bool):
        return value
    return str(value)


def _json(value: Any) -> bytes:
    text = value if isinstance(value, str) else json.dumps(value, ensure_ascii=False)
    return text.encode("utf-8", errors="surrogatepass")


def bounded(entry: Mapping[str, Any], limit: int = VALUE_LIMIT) -> dict[str, Any]:
    """``entry`` JSON-safe, each value cut at ``limit`` bytes (module docstring)."""
    out: dict[str, Any] = {}
    for key, value in plain(entry).items():
        if key in _NEVER_CUT or value is None or isinstance(value, bool | int | float):
            out[key] = value
            continue
        raw = _json(value)
        if len(raw) <= limit:
            out[key] = value
            continue
        out[key] = raw[:limit].decode("utf-8", errors="ignore")
        out[f"{key}_truncated"] = True
        out[f"{key}_bytes"] = len(raw)
        out[f"{key}_sha256"] = hashlib.sha256(raw).hexdigest()
    return out
