"""The configuration read with bounds: limits exact, no valid file refused, every float finite."""

from __future__ import annotations

import math
import tomllib
import types
import typing
from pathlib import Path

import pytest
from pydantic import BaseModel, ValidationError

from gateway.service.config import GatewayConfig, load_config
from gateway.service.config_bounds import (
    FileBounds,
    UnreadableConfig,
    decode,
    listed,
    read_toml,
    scan_toml,
)

EXAMPLE = Path(__file__).parents[2] / "deploy" / "cell.example.toml"

#: TOML whose strings and comments hold what the scan counts elsewhere: brackets, braces,
#: dots, quotes of the other kind, escaped quotes, quote runs closing a multi-line string.
DOTS = ".".join("abcdefghijklmnopqrstuvwxyz0123456789")  # 36 parts
Q3, A3 = '"' * 3, "'" * 3
TRICKY = "\n".join(
    [
        f"# a comment with [[[[ {{{{ and {DOTS}",
        f'title = "[[[[ {{{{ {DOTS} \\" ["',
        f"literal = '[[[[ \"{{{{\" {DOTS}'",
        f"multi = {Q3}",
        f"{'[' * 40} \\{Q3} {DOTS}",
        f'ends with two quotes{Q3}""',
        f"multi_literal = {A3}",
        f"{'{' * 40} '' {DOTS}",
        A3,
        "\"quoted.key\".'with [brackets]'.plain = 1.5",
        "when = 1979-05-27T07:32:00.999999Z",
        "numbers = [1.5, -0.25, 6.02e23, [[1.0], [2.0]], {a = {b = 0.5}}]",
        "",
    ]
)


def test_valid_toml_with_brackets_and_dots_in_strings_is_read_as_tomllib_reads_it(
    tmp_path: Path,
) -> None:
    path = tmp_path / "tricky.toml"
    path.write_text(TRICKY, "utf-8")
    assert read_toml(path) == tomllib.loads(TRICKY)


def test_the_annotated_example_passes_the_bounds() -> None:
    scan_toml(EXAMPLE.read_text("utf-8"))


@pytest.mark.parametrize(
    ("ok", "refused", "words"),
    [
        ("x = " + "[" * 32 + "]" * 32, "x = " + "[" * 33 + "]" * 33, "nested more than 32"),
        (
            "x = " + "{a = " * 32 + "1" + "}" * 32,
            "x = " + "{a = " * 33 + "1" + "}" * 33,
            "nested more than 32",
        ),
        ("a" + ".a" * 31 + " = 1", "a" + ".a" * 32 + " = 1", "dotted key of more than 32 parts"),
        ("[" + ".".join("t" * 32) + "]", "[" + ".".join("t" * 33) + "]", "more than 32 parts"),
        (
            'x = {"a"' + '."a"' * 31 + " = 1}",
            'x = {"a"' + '."a"' * 32 + " = 1}",
            "more than 32 parts",
        ),
    ],
)
def test_the_limits_are_exact(ok: str, refused: str, words: str) -> None:
    tomllib.loads(ok)  # the edge itself is valid TOML, and passes
    scan_toml(ok)
    with pytest.raises(UnreadableConfig, match=words):
        scan_toml(refused)


def test_size_encoding_and_binary_are_named() -> None:
    bounds = FileBounds(max_bytes=16)
    assert decode(b"x = 1" + b" " * 11, bounds) == "x = 1" + " " * 11
    with pytest.raises(UnreadableConfig, match="larger than 16 bytes"):
        decode(b"x = 1" + b" " * 12, bounds)
    with pytest.raises(UnreadableConfig, match=r"invalid byte 0xff at line 3, column 5"):
        decode(b"a = 1\nb = 2\nc = \xff\n")
    with pytest.raises(UnreadableConfig, match="a binary file"):
        decode(b"a = 1\n\0")


def test_load_config_names_the_file_and_why(tmp_path: Path) -> None:
    path = tmp_path / "cell.toml"
    path.write_bytes(b"a" + b".a" * 50_000 + b" = 1\n")
    with pytest.raises(Exception, match=rf"{path}: line 1, column 64: a dotted key"):
        load_config(path)


def test_listed_keeps_fifty_and_counts_the_rest() -> None:
    assert listed([str(i) for i in range(50)]) == [str(i) for i in range(50)]
    assert listed([str(i) for i in range(51)]) == [
        *(str(i) for i in range(50)),
        "... and 1 more problem(s)",
    ]


def _models(model: type[BaseModel], seen: dict[str, type[BaseModel]]) -> dict[str, type[BaseModel]]:
    """``model`` and every model it holds, by name."""
    if model.__name__ in seen:
        return seen
    seen[model.__name__] = model
    for info in model.model_fields.values():
        stack: list[object] = [info.annotation]
        while stack:
            kind = stack.pop()
            if isinstance(kind, type) and issubclass(kind, BaseModel):
                _models(kind, seen)
            elif isinstance(kind, types.UnionType) or typing.get_origin(kind) is not None:
                stack += typing.get_args(kind)
    return seen


def _is_float(annotation: object) -> bool:
    return annotation is float or float in typing.get_args(annotation)


def test_every_float_of_the_configuration_refuses_nan_and_infinity() -> None:
    # Walks the models as they are, so a float key added later is held to the rule as well.
    fields = [
        (model, name)
        for model in _models(GatewayConfig, {}).values()
        for name, info in model.model_fields.items()
        if _is_float(info.annotation)
    ]
    named = {(model.__name__, name) for model, name in fields}
    assert {("AxisSettings", "soft_max"), ("AxisSettings", "units_per_pulse")} <= named
    assert {("TimeoutSettings", "turnaround"), ("MqttSettings", "reconnect_max")} <= named
    for model, name in fields:
        for value in (math.nan, math.inf, -math.inf):
            with pytest.raises(ValidationError) as refused:
                model.model_validate({name: value})
            kinds = {e["type"] for e in refused.value.errors() if e["loc"] == (name,)}
            assert kinds == {"finite_number"}, (model, name, value, refused.value.errors())
