"""The gate every request body passes before a route sees it (a pure ASGI middleware).

A body is refused, with a problem naming the field and the rule, when it is:

* longer than ``BODY_LIMIT`` bytes: 413, from ``Content-Length`` before a byte is read, or
  as soon as the bytes read pass the limit (the rest is never read);
* not declared ``application/json`` (or ``+json``): 415 naming ``header.content-type``; a
  POST, PUT, PATCH or DELETE must be declared so even without a body (a browser sends such
  a request across sites only after asking the gateway, which says no);
* not UTF-8 (422 naming the byte), not JSON (422 naming line and column), nested deeper
  than ``MAX_DEPTH`` (422; far deeper, the parser's own recursion guard stops it early);
* holding something JSON cannot mean as a number or text (422 naming the field, such as
  ``body.position``): ``NaN``, ``Infinity``, a number too large for a double (``1e400``), an
  integer of more than ``MAX_DIGITS`` digits, a lone UTF-16 surrogate (``"\\ud800"``).

What passes is handed on unchanged, in one message: the route parses the same bytes.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from gateway.api.problems import Problem, problem_response, problem_type

__all__ = ["BODY_LIMIT", "MAX_DEPTH", "MAX_DIGITS", "BodyGate", "Refusal", "check_json"]

#: Bytes a request body may have: a program upload of 20,000 characters, each escaped as
#: ``\\uXXXX`` (6 bytes), fits with room to spare; nothing else comes near it.
BODY_LIMIT = 256 * 1024
#: Nesting of arrays and objects a body may have (the deepest request model has 3).
MAX_DEPTH = 32
#: Methods that act: each must be declared JSON, even without a body.
_ACTING = frozenset({"POST", "PUT", "PATCH", "DELETE"})
#: Digits an integer may have (a double holds 17 significant digits; positions have 8).
MAX_DIGITS = 20


@dataclass(frozen=True)
class Refusal:
    """Why a body is refused: the status, the field, the rule and what was found."""

    status: int
    field: str
    rule: str
    detail: str

    def problem(self) -> Problem:
        """The refusal as a problem (``invalid-input``, or the status's own type)."""
        slug = {413: "body-too-large", 415: "unsupported-media-type"}.get(
            self.status, "invalid-input"
        )
        title = {413: "Body too large", 415: "Unsupported media type"}.get(
            self.status, "Invalid input"
        )
        return Problem(
            type=problem_type(slug),
            title=title,
            status=self.status,
            detail=f"{self.field}: {self.detail}",
            field=self.field,
            rule=self.rule,
        )


def _too_large(size: int) -> Refusal:
    return Refusal(413, "body", f"at most {BODY_LIMIT} bytes", f"the body has {size} bytes or more")


class _NotFinite:
    """Stands for ``NaN``/``Infinity`` (or an integer too long) until its field is known."""

    def __init__(self, text: str) -> None:
        self.text = text


class _Numbers:
    """The parser's number hooks for one body: what JSON cannot mean becomes a ``_NotFinite``,
    and ``found`` says whether any did (then the body is walked to name its field)."""

    def __init__(self) -> None:
        self.found = False

    def _not_finite(self, text: str) -> _NotFinite:
        self.found = True
        return _NotFinite(text)

    def constant(self, text: str) -> _NotFinite:
        return self._not_finite(text)

    def integer(self, text: str) -> int | _NotFinite:
        digits = len(text.lstrip("-"))
        return self._not_finite(text[:24] + "...") if digits > MAX_DIGITS else int(text)

    def decimal(self, text: str) -> float | _NotFinite:
        value = float(text)
        return value if math.isfinite(value) else self._not_finite(text[:24])


#: an escaped UTF-16 surrogate in JSON text: the only way a body's text can hold one
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F]")


def _walk(value: Any, where: str) -> Iterator[tuple[str, Any, int]]:
    """Every key and value inside ``value`` with its field (``body.kinds.0``) and the depth of
    arrays and objects it is in (iterative: no recursion however deep the value)."""
    stack: list[tuple[str, Any, int]] = [(where, value, 0)]
    while stack:
        path, item, depth = stack.pop()
        yield path, item, depth
        if isinstance(item, dict):
            for key, inner in item.items():
                yield f"{path}.{key}", key, depth + 1
                stack.append((f"{path}.{key}", inner, depth + 1))
        elif isinstance(item, list):
            stack.extend((f"{path}.{i}", inner, depth + 1) for i, inner in enumerate(item))


def _is_text(value: str) -> bool:
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def check_json(raw: bytes) -> Refusal | None:
    """Why ``raw`` cannot be a request body (None: it can)."""
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        return Refusal(422, "body", "UTF-8 text", f"byte {exc.start} is not UTF-8")
    too_deep = Refusal(
        422, "body", f"JSON nested at most {MAX_DEPTH} deep", "the body is nested deeper"
    )
    numbers = _Numbers()
    try:
        value = json.loads(
            text,
            parse_constant=numbers.constant,
            parse_int=numbers.integer,
            parse_float=numbers.decimal,
        )
    except RecursionError:  # the parser's own guard, far deeper than MAX_DEPTH
        return too_deep
    except json.JSONDecodeError as exc:
        return Refusal(
            422,
            "body",
            "one JSON value (RFC 8259)",
            f"{exc.msg} at line {exc.lineno} column {exc.colno}",
        )
    # Walked only when something may be wrong: a wide body of plain values costs nothing more.
    may_be_deep = text.count("[") + text.count("{") > MAX_DEPTH
    if not (numbers.found or may_be_deep or _SURROGATE_ESCAPE.search(text)):
        return None
    for field, item, depth in _walk(value, "body"):
        if depth >= MAX_DEPTH and isinstance(item, dict | list):
            return too_deep
        if isinstance(item, _NotFinite):
            return Refusal(
                422,
                field,
                f"a finite number of at most {MAX_DIGITS} digits (NaN and Infinity are not JSON)",
                f"{item.text} is not a finite number",
            )
        if isinstance(item, str) and not _is_text(item):
            return Refusal(
                422,
                field,
                "Unicode text: a lone UTF-16 surrogate (\\ud800-\\udfff) is not a character",
                "a lone surrogate",
            )
    return None


def _header(scope: Scope, name: bytes) -> str | None:
    for key, value in scope.get("headers", ()):
        if key.lower() == name:
            return bytes(value).decode("latin-1")
    return None


def _is_json(content_type: str | None) -> bool:
    if not content_type:
        return False
    media = content_type.split(";", 1)[0].strip().lower()
    kind, _, subtype = media.partition("/")
    return kind == "application" and (subtype == "json" or subtype.endswith("+json"))


class BodyGate:
    """Refuse request bodies the API cannot mean (see the module's docstring)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """The ASGI entry point."""
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = _header(scope, b"content-length")
        if declared is not None and declared.strip().isdigit() and int(declared) > BODY_LIMIT:
            await self._refuse(_too_large(int(declared)), scope, receive, send)
            return
        raw = bytearray()
        more = True
        while more:
            message = await receive()
            if message["type"] != "http.request":  # the client went away
                await self.app(scope, _replay([message]), send)
                return
            raw += message.get("body", b"")
            more = bool(message.get("more_body", False))
            if len(raw) > BODY_LIMIT:
                await self._refuse(_too_large(len(raw)), scope, receive, send)
                return
        refusal = self._check(scope, bytes(raw))
        if refusal is not None:
            await self._refuse(refusal, scope, receive, send)
            return
        body: Message = {"type": "http.request", "body": bytes(raw), "more_body": False}
        await self.app(scope, _replay([body], receive), send)

    @staticmethod
    def _check(scope: Scope, raw: bytes) -> Refusal | None:
        acting = scope.get("method") in _ACTING
        if not raw and not acting:
            return None
        declared = _header(scope, b"content-type")
        if not _is_json(declared):
            # Bodyless acts too: a page of another site can send a POST without a body or
            # with a form or text type unasked, never one declared JSON (request_guard.py).
            return Refusal(
                415,
                "header.content-type",
                "application/json (or a +json type) on every POST, PUT, PATCH and DELETE, "
                "with a body or without",
                f"the request is declared {declared or 'as nothing'}",
            )
        return check_json(raw) if raw else None

    async def _refuse(self, refusal: Refusal, scope: Scope, receive: Receive, send: Send) -> None:
        # The refusal goes through the middlewares inside this one's caller (audit, metrics)
        # like any answer; headers tell the client the connection closes after a 413.
        headers = {"Connection": "close"} if refusal.status == 413 else {}
        problem = refusal.problem().model_copy(update={"instance": scope.get("path")})
        response = problem_response(problem, headers=headers)
        await response(scope, receive, send)


def _replay(messages: list[Message], then: Receive | None = None) -> Receive:
    """A ``receive`` giving ``messages`` first, then ``then``'s (a disconnect when waited on)."""
    pending = list(messages)

    async def receive() -> Message:
        if pending:
            return pending.pop(0)
        if then is not None:
            return await then()
        return {"type": "http.disconnect"}

    return receive
