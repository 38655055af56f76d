"""Command text to command model, and back.

``parse(text)`` turns the text between body number and CR into the model of the one form it
fits, or refuses it with an error that says why: an unknown mnemonic, a known mnemonic
written in no form of its own, or a parameter that breaks its rule (digit count, range,
characters). The registry is built from the catalog's explicit tuple; tests check that no
canonical text fits two forms.

Two contexts exist. HOST is what a host may send after '$' B#. PROGRAM is a user-program
statement after its '/': the chapter-12 commands plus the chapter-10 commands whose EEPROM
column is ○ (§11-3). The same letters can mean different things in each (``CO1`` reads
output bit 1 on the host, prints "1" in a program), so the context is always explicit.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass
from enum import StrEnum
from functools import cached_property
from typing import Annotated, Any, Union

from pydantic import Field, ValidationError

from gateway.errors import CommandFormError, InvalidInputError, ParameterError, UnknownCommandError
from gateway.protocol.catalog import ALL_COMMANDS
from gateway.protocol.models import Command, build_model, form_key
from gateway.protocol.params import Param, Position, PositionFormat
from gateway.protocol.spec import CommandSpec, Form

__all__ = [
    "REGISTRY",
    "Context",
    "Entry",
    "Registry",
    "command_union",
    "parse",
    "parse_statement",
]


class Context(StrEnum):
    """Where a command text stands."""

    HOST = "host"  # sent by the host after '$' B#
    PROGRAM = "program"  # a user-program statement after its '/'


@dataclass(frozen=True)
class Entry:
    """One form with its compiled patterns, and its model (built when first asked for)."""

    spec: CommandSpec
    form: Form
    strict: re.Pattern[str]
    loose: re.Pattern[str]

    @cached_property
    def model(self) -> type[Command]:
        """The pydantic model of the form. Built on first use: the catalog's 300-odd models
        take a good part of a second to create, which a command line that parses one text
        (``rc233-gateway parse``) should not pay."""
        return build_model(self.spec, self.form)

    @property
    def key(self) -> str:
        """The form key (its syntax; '/'-prefixed in chapter 12)."""
        return form_key(self.spec, self.form)

    @property
    def lead(self) -> str:
        """The literal text the form starts with (its mnemonic as written)."""
        first = self.form.tokens[0] if self.form.tokens else ""
        return first if isinstance(first, str) else ""

    def usable_in(self, context: Context) -> bool:
        """Whether the form may stand in this context."""
        if context is Context.HOST:
            return not self.spec.program_only
        return self.spec.program_only or self.spec.user_program


def _pattern(form: Form, loose: bool) -> re.Pattern[str]:
    parts: list[str] = []
    for token in form.tokens:
        if isinstance(token, str):
            parts.append(re.escape(token))
        else:
            fragment = token.loose() if loose else token.strict()
            parts.append(f"(?P<{token.name}>{fragment})")
    return re.compile("".join(parts), re.DOTALL)


def _decode(entry: Entry, match: re.Match[str]) -> dict[str, object]:
    values: dict[str, object] = {}
    for param in entry.form.params:
        text = match.group(param.name)
        values[param.name] = param.decode(text)
        if isinstance(param, Position) and text[:1] in "+-":
            values["signed"] = True
    return values


def _position_field(entry: Entry, message: str) -> str | None:
    """The position a model-level range check is about (those errors carry no location)."""
    names = [p.name for p in entry.form.params if isinstance(p, Position)]
    return next((n for n in names if f"{n}=" in message), names[0] if names else None)


def _rules(params: Iterable[Param]) -> str:
    return "; ".join(p.rule() for p in params)


class Registry:
    """Every form of the catalog, addressable by key and by text."""

    def __init__(self, commands: Iterable[CommandSpec]) -> None:
        self._entries: list[Entry] = []
        self._by_key: dict[str, Entry] = {}
        self._by_mnemonic: dict[str, CommandSpec] = {}
        for spec in commands:
            if spec.mnemonic in self._by_mnemonic:
                raise ValueError(f"mnemonic {spec.mnemonic!r} defined twice")
            self._by_mnemonic[spec.mnemonic] = spec
            for form in spec.forms:
                entry = Entry(spec, form, _pattern(form, False), _pattern(form, True))
                if entry.key in self._by_key:
                    raise ValueError(f"form key {entry.key!r} defined twice")
                self._by_key[entry.key] = entry
                self._entries.append(entry)

    @property
    def entries(self) -> tuple[Entry, ...]:
        """Every form, in catalog order."""
        return tuple(self._entries)

    @property
    def commands(self) -> tuple[CommandSpec, ...]:
        """Every command, in catalog order."""
        return tuple(self._by_mnemonic.values())

    def command(self, mnemonic: str) -> CommandSpec:
        """The command named ``mnemonic`` (``OH``, ``/JC``)."""
        try:
            return self._by_mnemonic[mnemonic]
        except KeyError:
            raise UnknownCommandError(
                f"no command {mnemonic!r} in the manual", field="mnemonic"
            ) from None

    def model(self, key: str) -> type[Command]:
        """The model of the form with this key (``OH{hs}``, ``""``, ``/JC{ct}{jump}``)."""
        try:
            return self._by_key[key].model
        except KeyError:
            raise UnknownCommandError(
                f"no command form {key!r} in the manual", field="command"
            ) from None

    def form(self, key: str) -> Form:
        """The form with this key, without building its model."""
        try:
            return self._by_key[key].form
        except KeyError:
            raise UnknownCommandError(
                f"no command form {key!r} in the manual", field="command"
            ) from None

    def build(
        self, key: str, values: dict[str, object], positions: PositionFormat | None = None
    ) -> Command:
        """The model of form ``key`` with parameter ``values``; ParameterError naming the
        field and its rule when one is broken (what ``parse`` raises for the same text)."""
        try:
            entry = self._by_key[key]
        except KeyError:
            raise UnknownCommandError(
                f"no command form {key!r} in the manual", field="command"
            ) from None
        return self._build(entry, values, positions)

    def matches(self, text: str, context: Context = Context.HOST) -> list[Entry]:
        """Forms of ``context`` whose strict pattern fits ``text`` (one in a sound catalog)."""
        return [e for e in self._entries if e.usable_in(context) and e.strict.fullmatch(text)]

    def parse(
        self,
        text: str,
        *,
        context: Context = Context.HOST,
        positions: PositionFormat | None = None,
    ) -> Command:
        """The model of the one form ``text`` fits; InvalidInputError saying why otherwise."""
        found = self.matches(text, context)
        if len(found) > 1:  # a catalog defect, caught by the registry tests
            keys = ", ".join(e.key for e in found)
            raise CommandFormError(f"{text!r} is ambiguous between {keys}", field="text")
        if found:
            entry = found[0]
            match = entry.strict.fullmatch(text)
            assert match is not None
            try:
                values = _decode(entry, match)
            except ParameterError as exc:
                raise ParameterError(
                    f"{entry.key}: {exc}", field=exc.field, rule=exc.rule
                ) from None
            return self._build(entry, values, positions)
        raise self._explain(text, context)

    def _build(
        self, entry: Entry, values: dict[str, object], positions: PositionFormat | None
    ) -> Command:
        context = {"positions": positions} if positions is not None else None
        try:
            return entry.model.model_validate(values, context=context)
        except ValidationError as exc:
            error = exc.errors()[0]
            field = str(error["loc"][0]) if error["loc"] else _position_field(entry, error["msg"])
            param = next((p for p in entry.form.params if p.name == field), None)
            rule = param.rule() if param else _rules(entry.form.params)
            raise ParameterError(f"{entry.key}: {error['msg']}", field=field, rule=rule) from None

    def _explain(self, text: str, context: Context) -> InvalidInputError:
        """The most useful error for text that fits no form."""
        other = Context.PROGRAM if context is Context.HOST else Context.HOST
        if self.matches(text, other):
            where = "only inside a user program" if other is Context.PROGRAM else "only by the host"
            return CommandFormError(f"{text!r} can be used {where}", field="text", rule=where)
        usable = [e for e in self._entries if e.usable_in(context)]
        best: tuple[int, int, ParameterError] | None = None
        for entry in usable:
            match = entry.loose.fullmatch(text)
            if match is None:
                continue
            failures: list[ParameterError] = []
            for param in entry.form.params:
                try:
                    param.decode(match.group(param.name))
                except ParameterError as exc:
                    failures.append(exc)
            if failures:
                ranked = (len(failures), len(failures) - len(entry.form.params), failures[0])
                if best is None or ranked[:2] < best[:2]:
                    failure = failures[0]
                    error = ParameterError(
                        f"{entry.key}: {failure}", field=failure.field, rule=failure.rule
                    )
                    best = (ranked[0], ranked[1], error)
        if best is not None:
            return best[2]
        leads = [e for e in usable if e.lead and text.startswith(e.lead)]
        if leads:
            longest = max(len(e.lead) for e in leads)
            spec = next(e.spec for e in leads if len(e.lead) == longest)
            forms = ", ".join(e.key for e in usable if e.spec is spec)
            return CommandFormError(
                f"{text!r} fits no form of {spec.mnemonic}: expected {forms}",
                field="text",
                rule=f"forms of {spec.mnemonic}: {forms}",
            )
        return UnknownCommandError(
            f"{text!r}: unknown command mnemonic", field="text", rule="a command of the manual"
        )


#: The registry of the whole catalog.
REGISTRY = Registry(ALL_COMMANDS)


def parse(
    text: str, *, context: Context = Context.HOST, positions: PositionFormat | None = None
) -> Command:
    """Parse host command text (between body number and CR) into its model."""
    return REGISTRY.parse(text, context=context, positions=positions)


def parse_statement(text: str, *, positions: PositionFormat | None = None) -> Command:
    """Parse one user-program statement (the text after its '/') into its model."""
    return REGISTRY.parse(text, context=Context.PROGRAM, positions=positions)


def command_union(context: Context = Context.HOST) -> Any:
    """``Annotated[Union[...], discriminator]`` of every model usable in ``context``.

    This is how an API accepts "any command of the catalog" as one typed JSON body:
    ``{"command": "OH{hs}", "hs": 4000}``.
    """
    models = tuple(e.model for e in REGISTRY.entries if e.usable_in(context))
    return Annotated[Union[models], Field(discriminator="command")]  # noqa: UP007
