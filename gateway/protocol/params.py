"""Parameter kinds of the command syntax, each with its own text rule.

A command form is written as a tuple of literal strings and parameters (see ``spec.Form``).
Each parameter kind knows three things about its piece of command text:

- its strict pattern (what the manual allows, used to recognise a form unambiguously),
- its loose pattern (what a careless writer might send, used only to give a precise error),
- how to turn the matched text into a value and back (``decode`` / ``encode``).

Values are plain ``int`` or ``str``; ranges are checked in ``decode`` and again by the
pydantic model built for the form, so a command is valid from the moment it exists.
"""

from __future__ import annotations

import re
from abc import ABC, abstractmethod
from dataclasses import dataclass
from enum import StrEnum
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field
from typing_extensions import override

from gateway.errors import ParameterError

__all__ = [
    "POSITION_MAX",
    "POSITION_MIN",
    "SIGNED_MAX",
    "UNSIGNED_MAX",
    "CharChoice",
    "Dec",
    "Digits",
    "HexDigit",
    "IntChoice",
    "Param",
    "Position",
    "PositionFormat",
    "exact_int",
]

#: The position counter is 24 bits wide (§10 EP): unsigned 0..16,777,215 or signed
#: -8,388,608..+8,388,607, two views of the same counter.
UNSIGNED_MAX = 16_777_215
SIGNED_MAX = 8_388_607
POSITION_MIN = -8_388_608
POSITION_MAX = UNSIGNED_MAX


class PositionFormat(StrEnum):
    """How a controller manages positions: EP0 unsigned, or EP1 / mode 1 signed (§10 EP, §7-4)."""

    UNSIGNED = "unsigned"
    SIGNED = "signed"

    @property
    def bounds(self) -> tuple[int, int]:
        """The inclusive range of positions in this format."""
        return (0, UNSIGNED_MAX) if self is PositionFormat.UNSIGNED else (POSITION_MIN, SIGNED_MAX)


@dataclass(frozen=True)
class Param(ABC):
    """One parameter of a command form."""

    name: str
    doc: str = ""

    @abstractmethod
    def strict(self) -> str:
        """Regex fragment for the text the manual allows."""

    def loose(self) -> str:
        """Regex fragment for text that is recognisably meant as this parameter."""
        return self.strict()

    @abstractmethod
    def rule(self) -> str:
        """The manual's rule in words, for error messages and the catalog."""

    @abstractmethod
    def decode(self, text: str) -> Any:
        """Turn matched text into a value, or raise ParameterError naming the rule."""

    def encode(self, value: Any) -> str:
        """Canonical text of a valid value."""
        return str(value)

    @abstractmethod
    def annotation(self) -> Any:
        """The pydantic type of the model field that holds this parameter."""

    def _fail(self, text: str, why: str) -> ParameterError:
        return ParameterError(f"{self.name}={text!r}: {why}", field=self.name, rule=self.rule())


@dataclass(frozen=True)
class Dec(Param):
    """A decimal number written with 1 to ``digits`` digits (``OH{hs}``: up to 5)."""

    lo: int = 0
    hi: int = 0
    digits: int = 5

    @override
    def strict(self) -> str:
        return rf"\d{{1,{self.digits}}}"

    @override
    def loose(self) -> str:
        # A one-digit parameter stays one digit, so that 'P1234567' blames time, not bt.
        return r"\d" if self.digits == 1 else r"\d+"

    @override
    def rule(self) -> str:
        digits = "1 digit" if self.digits == 1 else f"up to {self.digits} digits"
        return f"{self.name}: decimal {self.lo}-{self.hi}, {digits}"

    @override
    def decode(self, text: str) -> int:
        if not text.isdigit() or not text.isascii():
            raise self._fail(text, "must be decimal digits")
        if len(text) > self.digits:
            raise self._fail(text, f"at most {self.digits} digits, got {len(text)}")
        value = int(text)
        if not self.lo <= value <= self.hi:
            raise self._fail(text, f"out of range {self.lo}-{self.hi}")
        return value

    @override
    def annotation(self) -> Any:
        return Annotated[int, Field(ge=self.lo, le=self.hi, description=self.rule())]


@dataclass(frozen=True)
class Digits(Dec):
    """A decimal number written with exactly ``digits`` digits (position numbers: 000-999)."""

    @override
    def strict(self) -> str:
        return rf"\d{{{self.digits}}}"

    @override
    def rule(self) -> str:
        return f"{self.name}: exactly {self.digits} decimal digits, {self.lo}-{self.hi}"

    @override
    def decode(self, text: str) -> int:
        if len(text) != self.digits or not text.isdigit() or not text.isascii():
            raise self._fail(text, f"must be exactly {self.digits} decimal digits")
        return super().decode(text)

    @override
    def encode(self, value: Any) -> str:
        return f"{int(value):0{self.digits}d}"


@dataclass(frozen=True)
class HexDigit(Param):
    """One upper-case hexadecimal digit (port nibbles DU/DL, error mask of ``K``)."""

    lo: int = 0
    hi: int = 15

    @override
    def strict(self) -> str:
        return "[0-9A-F]"

    @override
    def loose(self) -> str:
        return "[0-9A-Za-z]"

    @override
    def rule(self) -> str:
        return f"{self.name}: one hex digit {self.lo:X}-{self.hi:X}"

    @override
    def decode(self, text: str) -> int:
        if len(text) != 1 or text not in "0123456789ABCDEF":
            raise self._fail(text, "must be one upper-case hex digit")
        value = int(text, 16)
        if not self.lo <= value <= self.hi:
            raise self._fail(text, f"out of range {self.lo:X}-{self.hi:X}")
        return value

    @override
    def encode(self, value: Any) -> str:
        return f"{int(value):X}"

    @override
    def annotation(self) -> Any:
        return Annotated[int, Field(ge=self.lo, le=self.hi, description=self.rule())]


def exact_int(value: Any) -> Any:
    """``value`` if it is an integer; a boolean or a decimal is refused, though ``True == 1``
    and ``1.0 == 1`` would pass pydantic's ``Literal[1, 2]`` even in strict mode."""
    if isinstance(value, bool) or (isinstance(value, float) and not isinstance(value, int)):
        raise ValueError("Input should be an integer, not a boolean or a decimal")
    return value


@dataclass(frozen=True)
class IntChoice(Param):
    """One digit out of a fixed set (motor number 1/2, counter 1/2, baud code 0-2)."""

    values: tuple[int, ...] = ()

    @override
    def strict(self) -> str:
        return "[" + "".join(str(v) for v in self.values) + "]"

    @override
    def loose(self) -> str:
        return r"\d"

    @override
    def rule(self) -> str:
        return f"{self.name}: one of {', '.join(str(v) for v in self.values)}"

    @override
    def decode(self, text: str) -> int:
        if len(text) != 1 or not text.isdigit() or int(text) not in self.values:
            raise self._fail(text, f"must be one of {', '.join(map(str, self.values))}")
        return int(text)

    @override
    def annotation(self) -> Any:
        return Annotated[
            Literal[self.values], BeforeValidator(exact_int), Field(description=self.rule())
        ]


@dataclass(frozen=True)
class CharChoice(Param):
    """One character out of a fixed set (direction +/-, buffer A-F, comparison <,=,>)."""

    values: tuple[str, ...] = ()

    @override
    def strict(self) -> str:
        return "(?:" + "|".join(re.escape(v) for v in self.values) + ")"

    @override
    def loose(self) -> str:
        return "."

    @override
    def rule(self) -> str:
        return f"{self.name}: one of {' '.join(self.values)}"

    @override
    def decode(self, text: str) -> str:
        if text not in self.values:
            raise self._fail(text, f"must be one of {' '.join(self.values)}")
        return text

    @override
    def annotation(self) -> Any:
        return Annotated[Literal[self.values], Field(description=self.rule())]


@dataclass(frozen=True)
class Position(Param):
    """A position in pulses: 8 digits unsigned (EP0) or sign + 7 digits signed (EP1, mode 1).

    The text form decides nothing by itself: which range applies depends on the controller's
    EP setting and mode, so the model checks the union here and the exact range when a
    ``PositionFormat`` is given as validation context (see ``models``).
    """

    @override
    def strict(self) -> str:
        return r"(?:[+-]\d{1,7}|\d{1,8})"

    @override
    def loose(self) -> str:
        return r"[+-]?\d+"

    @override
    def rule(self) -> str:
        return (
            f"{self.name}: unsigned 0-{UNSIGNED_MAX} (up to 8 digits, EP0) or signed "
            f"{POSITION_MIN}..+{SIGNED_MAX} (sign + up to 7 digits, EP1 or mode 1)"
        )

    @override
    def decode(self, text: str) -> int:
        body = text[1:] if text[:1] in "+-" else text
        if not body.isdigit() or not body.isascii():
            raise self._fail(text, "must be decimal digits with an optional sign")
        limit = 7 if text[:1] in "+-" else 8
        if len(body) > limit:
            raise self._fail(
                text, f"at most {limit} digits {'after the sign' if limit == 7 else ''}"
            )
        value = int(text)
        if not POSITION_MIN <= value <= POSITION_MAX:
            raise self._fail(text, "out of the 24-bit position range")
        if text[0] == "+" and value > SIGNED_MAX:
            raise self._fail(text, f"signed positions end at +{SIGNED_MAX}")
        return value

    @override
    def annotation(self) -> Any:
        return Annotated[int, Field(ge=POSITION_MIN, le=POSITION_MAX, description=self.rule())]
