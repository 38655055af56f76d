"""The OpenAPI document as integrators' tools read it: verbs, resources, headers, enum names.

Client generators turn the document into code, so its names become the integrator's names:

* operation ids read as verbs (``moveAxis``, ``homeAxis``, ``getOperation``), given centrally
  by ``operation_id`` (FastAPI's ``generate_unique_id_function``) from the route's name;
  a route whose name is not in ``OPERATION_IDS`` gets its name in camelCase;
* tags by resource, from the path (``TAGS``): health and metrics apart from the motion
  operations, leases and programs apart from the axes and controllers they belong to;
* ``Idempotency-Key`` declared on every POST and PUT, which the idempotency middleware honours;
* ``x-enum-varnames`` on every enum: the Python member names where the enum is a Python enum,
  else names made from the values (``+`` -> ``PLUS``, ``1`` of ``Motor`` -> ``MOTOR_1``).

``install_openapi_docs(app)`` wraps ``app.openapi`` like ``problem_docs`` does.
"""

from __future__ import annotations

import enum
import re
from collections.abc import Iterator
from typing import Any

from fastapi import FastAPI
from fastapi.routing import APIRoute

from gateway.api.middleware.idempotency import HEADER, MAX_KEY_LENGTH
from gateway.api.problem_docs import install_problem_docs

__all__ = ["OPERATION_IDS", "TAGS", "install_openapi_docs", "operation_id"]

#: Route name (by default the endpoint function's) -> operation id, where the name alone
#: does not read as a verb on its resource.
OPERATION_IDS: dict[str, str] = {
    "acknowledge": "acknowledgeAxisErrors",
    "home": "homeAxis",
    "jog": "jogAxis",
    "move": "moveAxis",
    "step": "stepAxis",
    "stop": "stopAxis",
    "get_speed": "getAxisSpeed",
    "put_speed": "setAxisSpeed",
    "post_command": "sendCommand",
    "eeprom_erase": "eraseEeprom",
    "eeprom_load": "loadEeprom",
    "eeprom_save": "saveEeprom",
    "get_io": "getIo",
    "put_outputs": "setOutputs",
    "put_output_bit": "setOutputBit",
    "pulse_output": "pulseOutputBit",
    "get_io_bit": "getIoBit",
    "get_mode": "getMode",
    "put_mode": "setMode",
    "get_position": "getPositionTableEntry",
    "put_position": "setPositionTableEntry",
    "put_program": "uploadProgram",
    "put_autostart": "setProgramAutostart",
    "get_autostart": "getProgramAutostart",
    "put_buffer": "setProgramBuffer",
    "put_counter": "setProgramCounter",
    "program_data": "getProgramData",
    "program_status": "getProgramStatus",
    "put_sensor_logic": "setSensorLogic",
    "post_raw": "sendRawCommand",
    "get_trace": "getLineTrace",
    "put_trace": "setLineTrace",
    "read_audit": "listAuditEntries",
    "healthz": "checkLiveness",
    "readyz": "checkReadiness",
    "metrics": "getMetrics",
}

#: (path pattern, tag, description), the first match wins.
TAGS: tuple[tuple[str, str, str], ...] = (
    (r"^/(healthz|readyz)$", "health", "Liveness and readiness probes"),
    (r"^/metrics$", "metrics", "Prometheus exposition"),
    (r"/lease$", "leases", "Control leases on axes and controllers"),
    (r"/control$", "control", "Local and remote control: lock out motion from the network"),
    (r"/program(/|$)", "programs", "User programs (chapters 11-12): upload, run, data"),
    (r"/axes(/|$)", "axes", "Axes: state, motion, speed, errors"),
    (r"/operations(/|$)", "operations", "Motion operations and how they went"),
    (r"/controllers(/|$)", "controllers", "Controllers: state, any command, I/O, EEPROM"),
    (r"/loops(/|$)", "loops", "Serial loops: link state, counters, raw commands, trace"),
    (r"/audit$", "audit", "The audit log of mutating requests"),
)

_VERB_PREFIXES = {"put": "set", "post": "send", "read": "list"}


def operation_id(route: APIRoute) -> str:
    """The operation id of ``route``: ``OPERATION_IDS`` or its name (the endpoint's function
    unless the route was given one) in camelCase."""
    name = route.name
    if name in OPERATION_IDS:
        return OPERATION_IDS[name]
    first, *rest = name.split("_")
    first = _VERB_PREFIXES.get(first, first)
    return first + "".join(word.capitalize() for word in rest)


def _tag(path: str) -> str | None:
    for pattern, tag, _ in TAGS:
        if re.search(pattern, path):
            return tag
    return None


def _idempotency_parameter() -> dict[str, Any]:
    return {
        "name": HEADER,
        "in": "header",
        "required": False,
        "description": "Retry safely: a POST or PUT repeated with the same key (same body and "
        "query) returns the first answer with `Idempotent-Replayed: true` instead of acting "
        "again; when the gateway stopped before the first answer was recorded, the retry is "
        "409 `idempotency-outcome-unknown` (it may have acted: check, do not repeat blindly)",
        "schema": {"type": "string", "pattern": f"^[ -~]{{1,{MAX_KEY_LENGTH}}}$"},
    }


def _python_enums() -> Iterator[type[enum.Enum]]:
    stack = [enum.Enum]
    while stack:
        cls = stack.pop()
        yield cls
        stack.extend(cls.__subclasses__())


def _member_names(title: str | None, values: list[Any]) -> list[str]:
    """The Python member names of the enum called ``title`` with exactly ``values``."""
    candidates = sorted(
        (c for c in _python_enums() if c.__name__ == title and [m.value for m in c] == values),
        key=lambda c: c.__module__,
    )
    if candidates:
        return [m.name for m in candidates[0]]
    prefix = re.sub(r"\W+", "_", title or "value").strip("_").upper()
    names = []
    for value in values:
        text = {"+": "PLUS", "-": "MINUS"}.get(str(value), str(value))
        text = re.sub(r"\W+", "_", text).strip("_").upper()
        names.append(text if text and not text[0].isdigit() else f"{prefix}_{text}")
    return names


def _name_enums(node: Any, title: str | None = None) -> None:
    if isinstance(node, dict):
        if "enum" in node and "x-enum-varnames" not in node:
            node["x-enum-varnames"] = _member_names(node.get("title", title), node["enum"])
        for key, value in node.items():
            _name_enums(value, key if key != "properties" and isinstance(value, dict) else title)
    elif isinstance(node, list):
        for item in node:
            _name_enums(item, title)


def document_for_integrators(schema: dict[str, Any]) -> None:
    """Tags by resource, ``Idempotency-Key`` on POSTs, enum names (see the module). Idempotent."""
    used: set[str] = set()
    for path, item in schema.get("paths", {}).items():
        for method, operation in item.items():
            if not isinstance(operation, dict):
                continue
            tag = _tag(path)
            if tag is not None:
                operation["tags"] = [tag]
            used.update(operation.get("tags", []))
            if method in ("post", "put"):
                parameters = operation.setdefault("parameters", [])
                if not any(p.get("name") == HEADER for p in parameters):
                    parameters.append(_idempotency_parameter())
    schema["tags"] = [
        {"name": tag, "description": description} for _, tag, description in TAGS if tag in used
    ] + [{"name": tag} for tag in sorted(used - {t for _, t, _ in TAGS})]
    _name_enums(schema.get("components", {}).get("schemas", {}))
    _name_enums(schema.get("paths", {}))


def install_openapi_docs(app: FastAPI) -> None:
    """Make ``app.openapi()`` the integrators' document: every error a ``Problem``
    (``install_problem_docs``), then ``document_for_integrators``."""
    install_problem_docs(app)
    original = app.openapi

    def openapi() -> dict[str, Any]:
        schema = original()
        document_for_integrators(schema)
        return schema

    app.openapi = openapi  # type: ignore[method-assign]
