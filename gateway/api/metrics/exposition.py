"""The Prometheus text exposition format 0.0.4, written by hand (no client library).

https://prometheus.io/docs/instrumenting/exposition_formats/: ``# HELP`` and ``# TYPE`` before
each family's samples, one block per family; label values escape backslash, double quote and
newline; ``+Inf``/``-Inf``/``NaN``; a histogram is cumulative ``_bucket{le=...}`` series ending
with ``le="+Inf"``, then ``_sum`` and ``_count``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

__all__ = ["Exposition", "Histogram"]


class Histogram:
    """Cumulative buckets, sum and count of observed values (one labelled series)."""

    def __init__(self, buckets: Iterable[float]) -> None:
        self.buckets = tuple(sorted(buckets))
        self.counts = [0] * len(self.buckets)
        self.sum = 0.0
        self.count = 0

    def observe(self, value: float) -> None:
        """Count ``value`` in every bucket it fits."""
        self.sum += value
        self.count += 1
        for i, bound in enumerate(self.buckets):
            if value <= bound:
                self.counts[i] += 1


def _escape(value: str) -> str:
    return value.replace("\\", "\\\\").replace("\n", "\\n").replace('"', '\\"')


def _number(value: float) -> str:
    if isinstance(value, int):
        return str(value)
    if math.isnan(value):
        return "NaN"
    if math.isinf(value):
        return "+Inf" if value > 0 else "-Inf"
    return repr(float(value))


class Exposition:
    """Lines of the text format: ``family`` (HELP, TYPE) then its ``sample``s."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def family(self, name: str, kind: str, help_text: str) -> None:
        """Begin family ``name`` of ``kind`` (counter, gauge, histogram)."""
        help_text = help_text.replace("\\", "\\\\").replace("\n", "\\n")
        self.lines += [f"# HELP {name} {help_text}", f"# TYPE {name} {kind}"]

    def sample(self, name: str, labels: Mapping[str, str], value: float) -> None:
        """One sample line of the current family."""
        inner = ",".join(f'{k}="{_escape(v)}"' for k, v in labels.items())
        self.lines.append(
            f"{name}{{{inner}}} {_number(value)}" if inner else f"{name} {_number(value)}"
        )

    def histogram(self, name: str, labels: Mapping[str, str], hist: Histogram) -> None:
        """The cumulative buckets, sum and count of one histogram series."""
        for bound, count in zip(hist.buckets, hist.counts, strict=True):
            self.sample(f"{name}_bucket", {**labels, "le": _number(float(bound))}, count)
        self.sample(f"{name}_bucket", {**labels, "le": "+Inf"}, hist.count)
        self.sample(f"{name}_sum", labels, hist.sum)
        self.sample(f"{name}_count", labels, hist.count)

    def text(self) -> str:
        """The whole exposition, newline-terminated."""
        return "\n".join(self.lines) + "\n"
