"""One pydantic model per command form, built from the catalog.

Every form of the catalog (``OH{hs}``, ``OH``, ``OHI{id}`` ...) becomes a frozen pydantic model
whose fields are its parameters, each constrained by the manual's rule, plus a ``command``
field holding the form's key (its syntax) as a literal: the discriminator that lets the API
accept "any command of the catalog" as one typed JSON body. A model is valid from the moment
it exists; ``wire()`` only writes it out.

Positions depend on the controller (EP0 unsigned, EP1 or mode 1 signed, §10 EP). A model
checks the union of both ranges on its own and the exact one when validated with
``context={"positions": PositionFormat.SIGNED}`` (or UNSIGNED); its ``signed`` field says
whether positions are written with a sign, as signed management requires.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Annotated, Any, ClassVar, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    ValidationInfo,
    create_model,
    model_validator,
)

from gateway.errors import GatewayError
from gateway.protocol.params import Param, Position, PositionFormat
from gateway.protocol.spec import CommandSpec, Form, ReplyFormat
from gateway.protocol.text_params import Jump, Label, Text

__all__ = ["Command", "build_model", "form_key", "model_name"]


class Command(BaseModel):
    """Base of every command model: one form of one command, with valid parameters."""

    # Strict: a parameter is given as its JSON type (an integer as a number, never "4000");
    # parse() decodes command text into those types first.
    model_config = ConfigDict(frozen=True, extra="forbid", strict=True)

    spec: ClassVar[CommandSpec]
    form: ClassVar[Form]
    key: ClassVar[str]

    @property
    def mnemonic(self) -> str:
        """The command's mnemonic as the manual names it (``OH``, ``B+(-)``, ``/JC``)."""
        return self.spec.mnemonic

    @property
    def reply_format(self) -> ReplyFormat:
        """The shape of the device's reply to this command."""
        return self.form.reply

    @property
    def motor(self) -> int | None:
        """The motor number given in the command (``MT``), if the form has one."""
        name = self.form.motor_param
        return int(getattr(self, name)) if name else None

    def params(self) -> dict[str, Any]:
        """The parameter values by name, in syntax order."""
        return {p.name: getattr(self, p.name) for p in self.form.params}

    def wire(self) -> str:
        """The command text between body number and CR (without the '/' of a program step)."""
        signed = bool(getattr(self, "signed", False))
        out: list[str] = []
        for token in self.form.tokens:
            if isinstance(token, str):
                out.append(token)
            elif isinstance(token, Position):
                value = int(getattr(self, token.name))
                out.append(f"{value:+d}" if signed else str(value))
            else:
                out.append(token.encode(getattr(self, token.name)))
        return "".join(out)

    def __str__(self) -> str:
        return self.wire()


def form_key(spec: CommandSpec, form: Form) -> str:
    """The form's identity: its syntax, '/'-prefixed for chapter-12 commands, '""' for status."""
    if spec.program_only:
        return "/" + form.syntax
    return form.syntax or '""'


_NAME_PIECES = (("///", "_erase"), ("*", "Star"), ("?", "Query"), (",", "_"), ("+", "Plus"))


def model_name(key: str) -> str:
    """A schema-safe class name for a form key: ``OH{hs}`` -> ``Cmd_OH_hs``."""
    if key == '""':
        return "Cmd_Status"
    if key == "/":
        return "Cmd_Prog_Wait"
    text = key
    for old, new in _NAME_PIECES:
        text = text.replace(old, new)
    text = "Prog_" + text[1:] if text.startswith("/") else text
    text = re.sub(r"\{(\w+)\}", r"_\1", text)
    return "Cmd_" + re.sub(r"[^A-Za-z0-9_]", "_", text)


def _checked(param: Param) -> Callable[[Any], Any]:
    """Run the parameter's own rule inside pydantic (which only catches ValueError)."""

    def check(value: Any) -> Any:
        try:
            param.decode(str(value))
        except GatewayError as exc:
            raise ValueError(str(exc)) from None
        return value

    return check


def _field(param: Param) -> tuple[Any, Any]:
    annotation = param.annotation()
    if isinstance(param, (Text, Label, Jump)):
        annotation = Annotated[annotation, AfterValidator(_checked(param))]
    return (annotation, Field(...))


def _check_positions(self: Command, info: ValidationInfo) -> Command:
    """Positions in the range of the controller's management, when the caller knows it."""
    positions = [p for p in self.form.params if isinstance(p, Position)]
    values = {p.name: int(getattr(self, p.name)) for p in positions}
    signed = bool(getattr(self, "signed", False))
    if any(v < 0 for v in values.values()) and not signed:
        raise ValueError("negative positions exist only in signed management (EP1 or mode 1)")
    context = info.context if isinstance(info.context, dict) else {}
    fmt = context.get("positions")
    if fmt is None:
        return self
    fmt = PositionFormat(fmt)
    lo, hi = fmt.bounds
    for name, value in values.items():
        if not lo <= value <= hi:
            raise ValueError(f"{name}={value} is outside {lo}..{hi} ({fmt.value} management)")
    if fmt is PositionFormat.UNSIGNED and signed:
        raise ValueError("a signed position was given to a controller in unsigned management (EP0)")
    return self


def _default_signed(names: tuple[str, ...]) -> Callable[[Any, ValidationInfo], Any]:
    """Signed management, or a negative position, implies the signed form (a sign on the wire)."""

    def default(data: Any, info: ValidationInfo) -> Any:
        if isinstance(data, dict) and "signed" not in data:
            context = info.context if isinstance(info.context, dict) else {}
            negative = any(isinstance(data.get(n), int) and data[n] < 0 for n in names)
            if negative or context.get("positions") == PositionFormat.SIGNED:
                return {**data, "signed": True}
        return data

    return default


def build_model(spec: CommandSpec, form: Form) -> type[Command]:
    """Create the pydantic model of one form."""
    key = form_key(spec, form)
    fields: dict[str, Any] = {p.name: _field(p) for p in form.params}
    fields["command"] = (Literal[key], Field(default=key, description=form.purpose))
    validators: dict[str, Any] = {}
    if form.has_positions:
        fields["signed"] = (
            bool,
            Field(default=False, description="write positions with a sign (EP1 or mode 1)"),
        )
        names = tuple(p.name for p in form.params if isinstance(p, Position))
        validators["_signed_default"] = model_validator(mode="before")(_default_signed(names))
        validators["_positions_in_range"] = model_validator(mode="after")(_check_positions)
    model: type[Command] = create_model(
        model_name(key),
        __base__=Command,
        __doc__=f"{key}: {form.purpose} (§{spec.section} {spec.mnemonic})",
        __validators__=validators,
        **fields,
    )
    model.spec = spec
    model.form = form
    model.key = key
    return model
