"""The catalog as data a person or a program can read (``rc233-gateway catalog``)."""

from __future__ import annotations

from typing import Any

from gateway.protocol.command_text import REGISTRY, Registry
from gateway.protocol.params import (
    POSITION_MAX,
    POSITION_MIN,
    CharChoice,
    Dec,
    Digits,
    HexDigit,
    IntChoice,
    Param,
    Position,
)
from gateway.protocol.spec import CommandSpec, Form

__all__ = ["catalog_json", "catalog_table"]


def _param(param: Param) -> dict[str, Any]:
    out: dict[str, Any] = {"name": param.name, "kind": type(param).__name__, "rule": param.rule()}
    if isinstance(param, (Dec, HexDigit)):
        out["min"], out["max"] = param.lo, param.hi
    if isinstance(param, Dec):
        out["digits"] = param.digits
        out["exact_digits"] = isinstance(param, Digits)
    if isinstance(param, (IntChoice, CharChoice)):
        out["values"] = list(param.values)
    if isinstance(param, Position):
        out["min"], out["max"] = POSITION_MIN, POSITION_MAX
    return out


def _form(spec: CommandSpec, form: Form, key: str) -> dict[str, Any]:
    return {
        "syntax": key,
        "purpose": form.purpose,
        "params": [_param(p) for p in form.params],
        "reply": form.reply.value,
        "effect": form.effect.value,
        "idempotent": form.idempotent,
        "while_moving": spec.form_while_moving(form),
        "modes": sorted(spec.form_modes(form)),
        "selects_motor": form.selects_motor,
        "clears_on_read": form.clears_on_read,
    }


def catalog_json(registry: Registry = REGISTRY) -> list[dict[str, Any]]:
    """One object per mnemonic. Command-level ``idempotent`` and ``while_moving`` describe the
    command's first (main) form; each form carries its own values."""
    by_spec: dict[str, list[dict[str, Any]]] = {}
    for entry in registry.entries:
        by_spec.setdefault(entry.spec.mnemonic, []).append(_form(entry.spec, entry.form, entry.key))
    out: list[dict[str, Any]] = []
    for spec in registry.commands:
        forms = by_spec[spec.mnemonic]
        out.append(
            {
                "mnemonic": spec.mnemonic,
                "title": spec.title,
                "section": spec.section,
                "forms": forms,
                "modes": sorted(spec.modes),
                "while_moving": spec.while_moving,
                "user_program": spec.user_program,
                "scope": spec.scope.value,
                "persisted_by": spec.persisted_by.value,
                "default": spec.default,
                "idempotent": forms[0]["idempotent"],
            }
        )
    return out


def catalog_table(registry: Registry = REGISTRY) -> str:
    """The catalog as a fixed-width text table, one line per form."""
    header = ("mnemonic", "form", "reply", "modes", "moving", "scope", "idem", "title")
    rows: list[tuple[str, ...]] = [header]
    for entry in registry.entries:
        spec, form = entry.spec, entry.form
        rows.append(
            (
                spec.mnemonic or '""',
                entry.key,
                form.reply.value,
                "".join(str(m) for m in sorted(spec.form_modes(form))),
                "yes" if spec.form_while_moving(form) else "no",
                spec.scope.value,
                "yes" if form.idempotent else "no",
                spec.title,
            )
        )
    widths = [max(len(r[i]) for r in rows) for i in range(len(header) - 1)]
    lines = [
        "  ".join(c.ljust(w) for c, w in zip(r[:-1], widths, strict=True)) + "  " + r[-1]
        for r in rows
    ]
    lines.append("")
    lines.append("Ranges: rc233-gateway catalog --json")
    return "\n".join(lines)
