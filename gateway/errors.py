"""The gateway's one exception tree.

    GatewayError
    ├── InvalidInputError ........ refused before anything reached the wire (field + rule)
    │   ├── UnknownCommandError .. no command of the manual starts like this text
    │   ├── CommandFormError ..... a known mnemonic, but the text fits none of its forms
    │   ├── ParameterError ....... a parameter breaks its rule (digit count, range, characters)
    │   └── ProgramError ......... a user program breaks a rule of chapters 11-12 (names the step)
    └── ProtocolError ............ bytes from the device are not what the manual allows
        └── ReplyFormatError ..... a reply's data part does not decode as its command's reply

Every InvalidInputError carries ``field`` (the parameter or input it is about, or None when
it is about the whole text) and ``rule`` (the manual's rule, in words), so that the API layer
can map it to a problem+json response without parsing messages.
"""

from __future__ import annotations

__all__ = [
    "CommandFormError",
    "GatewayError",
    "InvalidInputError",
    "ParameterError",
    "ProgramError",
    "ProtocolError",
    "ReplyFormatError",
    "UnknownCommandError",
]


class GatewayError(Exception):
    """Base of every error the gateway raises on purpose."""


class InvalidInputError(GatewayError):
    """Input refused by the manual's rules; nothing was sent."""

    def __init__(self, message: str, *, field: str | None = None, rule: str = "") -> None:
        super().__init__(message)
        self.field = field
        self.rule = rule or message


class UnknownCommandError(InvalidInputError):
    """The text starts with no mnemonic the manual defines."""


class CommandFormError(InvalidInputError):
    """The mnemonic is known, but the text fits none of its forms."""


class ParameterError(InvalidInputError):
    """A parameter breaks its rule: digit count, range or characters."""


class ProgramError(InvalidInputError):
    """A user program breaks a rule of chapters 11-12.

    ``step`` counts statements the way the device's ``GN`` does: the first statement is step 1
    (``//`` counts two); step 0 means the program as a whole (empty, or a bad first character).
    """

    def __init__(
        self, message: str, *, step: int, field: str | None = None, rule: str = ""
    ) -> None:
        super().__init__(f"step {step}: {message}", field=field, rule=rule or message)
        self.step = step


class ProtocolError(GatewayError):
    """Bytes from the device do not fit what the manual allows."""


class ReplyFormatError(ProtocolError):
    """A reply's data part does not decode as the reply its command defines."""
