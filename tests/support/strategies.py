"""hypothesis strategies that build valid parameter values from the catalog's own rules."""

from __future__ import annotations

from typing import Any

from hypothesis import strategies as st

from gateway.protocol.command_text import Entry
from gateway.protocol.params import (
    CharChoice,
    Dec,
    HexDigit,
    IntChoice,
    Param,
    Position,
)
from gateway.protocol.text_params import Jump, Label, Text

LABEL_CHARS = "0123456789@%&*=<>?!\uff71\uff72"
LOWER = "abcdefghijklmnopqrstuvwxyz"


def param_values(param: Param) -> st.SearchStrategy[Any]:
    """Valid values of one parameter."""
    if isinstance(param, (Dec, HexDigit)):
        return st.integers(param.lo, param.hi)
    if isinstance(param, (IntChoice, CharChoice)):
        return st.sampled_from(param.values)
    if isinstance(param, Position):
        return st.integers(-8_388_608, 16_777_215)
    if isinstance(param, Text):
        alphabet = st.characters(min_codepoint=0x20, max_codepoint=0x7E, exclude_characters="$/")
        return st.text(alphabet, min_size=1, max_size=param.max_len)
    if isinstance(param, Label):
        return st.sampled_from(LABEL_CHARS if param.host else LABEL_CHARS + LOWER)
    if isinstance(param, Jump):
        return st.one_of(
            st.builds(lambda s, n: f"{s}{n}", st.sampled_from("+-"), st.integers(0, 999)),
            st.builds(lambda n: f"A{n}", st.integers(1, 999)),
            st.builds(
                lambda lb, n: f"G{lb}{n}", st.sampled_from(LABEL_CHARS + LOWER), st.integers(1, 999)
            ),
        )
    raise AssertionError(f"no strategy for {param!r}")


def form_values(entry: Entry) -> st.SearchStrategy[dict[str, Any]]:
    """A valid parameter dict for a form (a negative position implies the signed form)."""
    return st.fixed_dictionaries({p.name: param_values(p) for p in entry.form.params})
