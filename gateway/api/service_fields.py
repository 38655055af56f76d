"""The HTTP fields of the service's refusals: the service names its own argument (``position``,
``baud``, ``text.jump``) or the command parameter a constructor refused (``pn``, ``bit``); only
this face knows whether a route took it from its body or its path.

``http_field`` gives the field a problem+json names, per route (the route's name): an
argument's error is told as the body or path field it came from; a command parameter's
(``ParameterError``) as a field of the route's ``parameters`` location. Everything else keeps
the field it was raised with (``axis``, ``command``, ``query.axis`` ...).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from starlette.requests import Request

from gateway.errors import ConflictError, InvalidInputError, ParameterError

__all__ = ["ROUTE_FIELDS", "RouteFields", "http_field"]


@dataclass(frozen=True)
class RouteFields:
    """Where one route's service arguments come from."""

    #: an argument the service names in an ``InvalidInputError`` -> the HTTP field
    invalid: Mapping[str, str] = field(default_factory=dict)
    #: an argument the service names in a ``ConflictError`` -> the HTTP field
    conflict: Mapping[str, str] = field(default_factory=dict)
    #: where the route's command parameters come from (``path``, ``body``), if it has any
    parameters: str | None = None


def _body(*names: str) -> dict[str, str]:
    return {name: f"body.{name}" for name in names}


_SPEED = ("oh", "ol", "os", "oc", "ox")

#: Per route name (the handler's), where the arguments of its service call come from.
ROUTE_FIELDS: Mapping[str, RouteFields] = {
    "move": RouteFields(_body("position")),
    "jog": RouteFields(_body("position", "direction"), conflict=_body("speed")),
    "step": RouteFields(_body("position")),
    # ``change`` is the set of speed data given: the body as a whole
    "put_speed": RouteFields({**_body(*_SPEED), "change": "body"}),
    "post_loop_baud": RouteFields(_body("baud")),
    "put_program": RouteFields(_body("text")),
    "check_program": RouteFields(_body("text")),
    "run_program": RouteFields(_body("label")),
    "get_position": RouteFields(parameters="path"),
    "put_position": RouteFields(_body("position"), parameters="path"),
    "get_io_bit": RouteFields(parameters="path"),
    "put_outputs": RouteFields(parameters="body"),
    "put_output_bit": RouteFields(parameters="path"),
    "pulse_output": RouteFields(parameters="path"),
    "put_sensor_logic": RouteFields(parameters="body"),
    "put_mode": RouteFields(parameters="body"),
    "put_buffer": RouteFields(parameters="path"),
    "put_counter": RouteFields(parameters="path"),
    "eeprom_save": RouteFields(_body("area")),
    "eeprom_load": RouteFields(_body("area")),
}


def _renamed(name: str | None, fields: Mapping[str, str]) -> str | None:
    """``name`` (``text.jump``) with its first part replaced by its HTTP field, if listed."""
    if name is None:
        return None
    head, dot, rest = name.partition(".")
    return fields[head] + dot + rest if head in fields else name


def http_field(request: Request, exc: Exception, name: str | None) -> str | None:
    """The field a problem about ``exc`` names, raised with ``name``, on ``request``'s route."""
    route = request.scope.get("route")
    fields = ROUTE_FIELDS.get(getattr(route, "name", ""))
    if fields is None:
        return name
    if isinstance(exc, ParameterError) and fields.parameters is not None:
        return f"{fields.parameters}.{name}" if name else fields.parameters
    if isinstance(exc, InvalidInputError):
        return _renamed(name, fields.invalid)
    if isinstance(exc, ConflictError):
        return _renamed(name, fields.conflict)
    return name
