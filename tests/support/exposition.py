"""The Prometheus text exposition read back: samples by name and labels."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

_NAME = r"[a-zA-Z_:][a-zA-Z0-9_:]*"
_SAMPLE = re.compile(rf"^({_NAME})(?:\{{(.*)\}})? (\S+)$")
_LABEL = re.compile(rf'({_NAME})="((?:[^"\\]|\\.)*)"(,|$)')
_SUFFIXES = ("_bucket", "_sum", "_count")

Labels = frozenset[tuple[str, str]]


@dataclass
class Family:
    kind: str
    help: str
    samples: dict[tuple[str, Labels], float] = field(default_factory=dict)


def parse_exposition(text: str) -> dict[str, Family]:
    """Parse the text format 0.0.4 strictly: HELP and TYPE before a family's samples, each
    family in one block, label values escaped, numbers valid."""
    assert text.endswith("\n")
    families: dict[str, Family] = {}
    current: str | None = None
    pending_help: tuple[str, str] | None = None
    for line in text.splitlines():
        if line.startswith("# HELP "):
            name, _, help_text = line[7:].partition(" ")
            assert name not in families, f"family {name} appears twice"
            pending_help = (name, help_text)
        elif line.startswith("# TYPE "):
            name, _, kind = line[7:].partition(" ")
            assert pending_help is not None and pending_help[0] == name, line
            assert kind in ("counter", "gauge", "histogram", "summary", "untyped"), line
            families[name] = Family(kind, pending_help[1])
            current = name
        else:
            match = _SAMPLE.match(line)
            assert match, f"not a sample line: {line!r}"
            sample, inner, value = match.groups()
            assert current is not None and (
                sample == current
                or (families[current].kind == "histogram" and sample[len(current) :] in _SUFFIXES)
            ), f"{sample} outside its family block (in {current})"
            labels: list[tuple[str, str]] = []
            rest = inner or ""
            while rest:
                lm = _LABEL.match(rest)
                assert lm, f"bad labels in {line!r}"
                raw = lm.group(2)
                unescaped = re.sub(r"\\(.)", lambda m: {"n": "\n"}.get(m[1], m[1]), raw)
                labels.append((lm.group(1), unescaped))
                rest = rest[lm.end() :]
            number = float(value)  # accepts +Inf, NaN
            families[current].samples[(sample, frozenset(labels))] = number
    return families


def value(fams: dict[str, Family], sample: str, **labels: str) -> float:
    family = (
        fams[re.sub(r"_(bucket|sum|count)$", "", sample)] if sample not in fams else fams[sample]
    )
    return family.samples[(sample, frozenset(labels.items()))]
