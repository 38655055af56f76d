"""What a motion operation was asked to do: one typed model per kind, told apart by ``kind``.

``AxisService`` builds the model once from its own typed arguments; the ``Operation`` keeps it
as it is, its view hands the same instance on (no validation again), and the state store
keeps its fields as JSON beside the operation's ``kind`` (``asked_of`` reads them back).

``kind`` is the discriminator inside the gateway; clients read it from the operation's own
``kind`` field, so it is left out of what the model serialises: the ``request`` object that
clients receive holds the asked fields only, as it always has.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter

from gateway.service.operations.terms import Direction, HomeMethod, JogSpeed, Unit

__all__ = [
    "Asked",
    "HomeAsked",
    "JogAsked",
    "MoveAsked",
    "StepAsked",
    "asked_of",
    "asked_record",
]


class _Asked(BaseModel):
    # Frozen: a change (a jog's new speed) is a new model on the operation, never an edit of
    # one a view or an event may still hold. Extra fields refused: a record with a field the
    # kind does not have is a broken record, not a request.
    model_config = ConfigDict(frozen=True, extra="forbid")


class MoveAsked(_Asked):
    """A move as asked (kind ``move``)."""

    kind: Literal["move"] = Field(default="move", exclude=True)
    position: float
    relative: bool
    unit: Unit


class HomeAsked(_Asked):
    """An origin search as asked (kind ``home``)."""

    kind: Literal["home"] = Field(default="home", exclude=True)
    method: HomeMethod


class JogAsked(_Asked):
    """A jog as asked (kind ``jog``); ``speed`` follows a later change of speed."""

    kind: Literal["jog"] = Field(default="jog", exclude=True)
    direction: Direction
    speed: JogSpeed


class StepAsked(_Asked):
    """One pulse as asked (kind ``step``)."""

    kind: Literal["step"] = Field(default="step", exclude=True)
    direction: Direction


#: One asked motion, its model chosen by ``kind``.
Asked = Annotated[MoveAsked | HomeAsked | JogAsked | StepAsked, Field(discriminator="kind")]

_ASKED: TypeAdapter[Asked] = TypeAdapter(Asked)


def asked_of(kind: str, fields: Mapping[str, Any]) -> Asked:
    """The asked model of an operation of ``kind`` from its stored ``fields`` (the ``request``
    object of an operation record, without ``kind``); a ``ValidationError`` when they do not
    fit the kind."""
    return _ASKED.validate_python({**fields, "kind": kind})


def asked_record(asked: Asked) -> dict[str, Any]:
    """The fields of ``asked`` as the state store keeps them (JSON-able, without ``kind``)."""
    return asked.model_dump(mode="json")
