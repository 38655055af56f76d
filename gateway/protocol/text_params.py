"""Parameters written as text: a printed message, a label, a jump operand (§10 G, §11-3, §12).

They hold characters rather than numbers, so their rules are about which characters may stand
where: never the '$', '/' or CR that would end the frame or the statement.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Annotated, Any

from pydantic import Field
from typing_extensions import override

from gateway.protocol.params import Param

__all__ = ["Jump", "Label", "Text", "jump_count"]

#: Characters that may never stand inside a parameter: '$' starts a command, '/' starts a
#: user-program statement, CR ends a frame (§10 I, §11-3).
_NEVER_IN_TEXT = "$/\r"

#: Label characters (§10 G, §11-3, §12 /G): one half-width character, not '$', '#', '/',
#: not upper-case A-Z (they would collide with GA, GC, GE, GN, GR, GS, GW); lower-case a-z
#: only as jump targets. Half-width katakana (U+FF61..U+FF9F) are allowed; see
#: docs/manual-notes.md "Label characters".
_LABEL_RE = r"[0-9a-z!\"%&'()*+,\-.:;<=>?@\[\\\]^_`{|}~\uff61-\uff9f]"


@dataclass(frozen=True)
class Text(Param):
    """Free text (``/CO`` message): printable, no '$', '/' or CR, at most ``max_len``."""

    max_len: int = 20

    @override
    def strict(self) -> str:
        return rf"[^$/\r\n]{{1,{self.max_len}}}"

    @override
    def loose(self) -> str:
        return r"[^/]*"

    @override
    def rule(self) -> str:
        return f"{self.name}: 1-{self.max_len} characters, none of '$', '/', CR"

    @override
    def decode(self, text: str) -> str:
        if not 1 <= len(text) <= self.max_len:
            raise self._fail(text, f"must be 1-{self.max_len} characters")
        if any(c in _NEVER_IN_TEXT or c == "\n" for c in text):
            raise self._fail(text, "must not contain '$', '/' or CR")
        return text

    @override
    def annotation(self) -> Any:
        return Annotated[
            str,
            Field(
                min_length=1,
                max_length=self.max_len,
                pattern=r"^[^$/\r\n]+$",
                description=self.rule(),
            ),
        ]


@dataclass(frozen=True)
class Label(Param):
    """A user-program label: one half-width character (see ``_LABEL_RE``)."""

    host: bool = False  # the host can start only at labels other than a-z (§10 G, Ver 1.18)

    @override
    def strict(self) -> str:
        return _LABEL_RE.replace("a-z", "") if self.host else _LABEL_RE

    @override
    def loose(self) -> str:
        return "."

    @override
    def rule(self) -> str:
        extra = "; lower-case a-z only as jump targets" if self.host else ""
        return f"{self.name}: one half-width character, not A-Z, '$', '#' or '/'{extra}"

    @override
    def decode(self, text: str) -> str:
        if not re.fullmatch(self.strict(), text):
            raise self._fail(text, "is not a usable label character")
        return text

    @override
    def annotation(self) -> Any:
        return Annotated[str, Field(pattern="^" + self.strict() + "$", description=self.rule())]


#: Jump operands (§12 jumps): +DT and -DT relative to the next statement (0-999), ADT
#: absolute from statement 1 (1-999), G{LB}{DT} relative to label LB (1-999).
_JUMP_RE = r"(?:[+-]\d{1,3}|A\d{1,3}|G" + _LABEL_RE + r"\d{1,3})"


@dataclass(frozen=True)
class Jump(Param):
    """A jump operand of /J, /JB, /JC ... /SC: ``+n``, ``-n``, ``An`` or ``G<label>n``."""

    @override
    def strict(self) -> str:
        return _JUMP_RE

    @override
    def loose(self) -> str:
        return ".+"

    @override
    def rule(self) -> str:
        return f"{self.name}: +n or -n (0-999), An (1-999) or G<label>n (1-999)"

    @override
    def decode(self, text: str) -> str:
        if not re.fullmatch(_JUMP_RE, text):
            raise self._fail(text, "is not a jump operand (+n, -n, An or G<label>n)")
        if jump_count(text) < 1 and text[0] in "AG":
            raise self._fail(text, "absolute and label jumps count from 1")
        return text

    @override
    def annotation(self) -> Any:
        return Annotated[str, Field(pattern="^" + _JUMP_RE + "$", description=self.rule())]


def jump_count(operand: str) -> int:
    """The number of a jump operand: after its sign, after ``A``, or after ``G`` and the label."""
    return int(operand[2:] if operand[0] == "G" else operand[1:])
