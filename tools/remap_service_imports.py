"""Rewrite the imports of a branch made before service/ was split by resource.

For the merge that brings such a branch in: run it over the files that branch added or
changed (``git diff --name-only main...BRANCH -- '*.py'``), then ruff --fix. It maps each old
module path to its new home, ``Gateway`` (the running gateway) to ``Runtime``,
``install_operations`` to ``install_health_and_metrics``, and an api/ or mqtt/ import of the
bus's ``AxisState`` to ``service/runtime/bus_types.py``. Delete this file once no such branch
is left.

    python3 tools/remap_service_imports.py FILE...
"""

from __future__ import annotations

import re
import sys

MOVES = {
    "axes": "axes.service",
    "axis_speeds": "axes.speeds",
    "position_format": "axes.position_format",
    "soft_limits": "axes.soft_limits",
    "limit_jog": "axes.limit_jog",
    "axis_types": "operations.terms",
    "operations": "operations.registry",
    "operation_types": "operations.types",
    "motion_watch": "operations.motion_watch",
    "controllers": "controllers.service",
    "ctl_replies": "controllers.replies",
    "ctl_resources": "controllers.resources",
    "ctl_models": "controllers.views",
    "programs": "controllers.programs",
    "gateway": "runtime.runtime",
    "key_switch": "runtime.key_switch",
    "simulated": "runtime.simulated",
    "state_log": "runtime.state_log",
}
OLD = re.compile(r"\bgateway\.service\.(" + "|".join(MOVES) + r")\b(?!\.)")


def remap(path: str, text: str) -> str:
    """``text`` (of the file at ``path``) with the new import paths and names."""
    text = OLD.sub(lambda m: "gateway.service." + MOVES[m.group(1)], text)
    text = re.sub(
        r"from gateway\.service\.runtime\.runtime import Gateway\b",
        "from gateway.service.runtime.runtime import Runtime",
        text,
    )
    if "gateway.service.runtime.runtime import Runtime" in text:
        text = re.sub(r"(?<![\w.\"'])Gateway\b", "Runtime", text)
    if "/api/" in path or "/mqtt/" in path:
        text = text.replace(
            "from gateway.bus.state_types import AxisState",
            "from gateway.service.runtime.bus_types import AxisState",
        )
    if "install_operations =" not in text:  # not api/health.py, which keeps the old name
        text = text.replace("install_operations", "install_health_and_metrics")
    return text


def main(paths: list[str]) -> None:
    """Rewrite each file of ``paths`` in place; name those changed."""
    for path in paths:
        if path.endswith("remap_service_imports.py"):
            continue
        with open(path, encoding="utf-8") as file:
            text = file.read()
        new = remap(path, text)
        if new != text:
            with open(path, "w", encoding="utf-8") as file:
                file.write(new)
            print("rewrote", path)


if __name__ == "__main__":
    main(sys.argv[1:])
