"""The gateway's one exception tree.

    GatewayError
    ├── InvalidInputError ........ refused before anything reached the wire (field + rule)
    │   ├── UnknownCommandError .. no command of the manual starts like this text
    │   ├── CommandFormError ..... a known mnemonic, but the text fits none of its forms
    │   ├── ParameterError ....... a parameter breaks its rule (digit count, range, characters)
    │   └── ProgramError ......... a user program breaks a rule of chapters 11-12 (names the step)
    ├── ProtocolError ............ bytes from the device are not what the manual allows
    │   └── ReplyFormatError ..... a reply's data part does not decode as its command's reply
    └── ServiceError ............. what the service layer refuses or could not do
        ├── NotFoundError ........ no loop, controller, axis or operation by that id or name
        ├── ConflictError ........ the resource is busy: moving, leased by another client
        ├── DeviceError .......... the device did not answer, or its answer leaves doubt
        └── StateUnavailable ..... the state store cannot record it: nothing was done

Every InvalidInputError carries ``field`` (the parameter or input it is about, or None when
it is about the whole text) and ``rule`` (the manual's rule, in words), so that the API layer
can map it to a problem+json response without parsing messages.
"""

from __future__ import annotations

__all__ = [
    "CommandFormError",
    "ConflictError",
    "DeviceError",
    "GatewayError",
    "InvalidInputError",
    "NotFoundError",
    "ParameterError",
    "ProgramError",
    "ProtocolError",
    "ReplyFormatError",
    "ServiceError",
    "StateUnavailable",
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


class ServiceError(GatewayError):
    """Base of what the service layer refuses or could not carry out."""


class NotFoundError(ServiceError):
    """No resource of ``kind`` ('loop', 'controller', 'axis', 'operation') is called ``ident``."""

    def __init__(
        self, kind: str, ident: str, *, known: tuple[str, ...] = (), field: str | None = None
    ) -> None:
        hint = f"; known: {', '.join(known[:20])}" if known else ""
        super().__init__(f"no {kind} {ident!r}{hint}")
        self.kind = kind
        self.ident = ident
        #: the request field that named it (``query.axis``), when not the path
        self.field = field


class ConflictError(ServiceError):
    """The resource cannot take the request now (moving, leased by another client, busy).

    ``field`` names the request field or resource the conflict is about, ``holder`` the client
    holding a lease (None when the conflict is not a lease).
    """

    def __init__(self, message: str, *, field: str | None = None, holder: str | None = None):
        super().__init__(message)
        self.field = field
        self.holder = holder


class DeviceError(ServiceError):
    """The device did not answer (time-out), or what came back leaves the outcome in doubt.

    ``outcome`` is the scheduler's verdict ('not_done' or 'unknown'), ``detail`` what was seen.
    """

    def __init__(self, message: str, *, outcome: str = "unknown", timeout: bool = False) -> None:
        super().__init__(message)
        self.outcome = outcome
        self.timeout = timeout


class StateUnavailable(ServiceError):
    """What must be recorded before it acts (an operation) could not be written to the state
    store (disk full, read-only, I/O error): nothing was sent, a retry later may succeed."""
