"""Every message of the WebSocket ``/api/v1/ws``, as pydantic models, and their JSON Schema.

Client messages are validated with ``ClientMessage`` (a message that does not fit is answered
with an ``error`` naming the field and the rule). Server messages are written by the feed
(``gateway.service.feed``) and the endpoint (``api.ws.endpoint``); ``ServerMessage`` documents
them, and the tests validate every message a server sent against ``ws_schema()``, which
``rc233-gateway openapi`` writes to ``openapi/websocket.json``.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, RootModel
from pydantic.json_schema import models_json_schema

from gateway.service.events import EventKind
from gateway.service.feed import TOPIC_RULE
from gateway.service.views import AxisView, ControllerView, LoopView

__all__ = [
    "CLOSE_CODES",
    "ChangeMessage",
    "ClientMessage",
    "ErrorMessage",
    "EventMessage",
    "PingMessage",
    "PongMessage",
    "ServerMessage",
    "SnapshotMessage",
    "SubscribeMessage",
    "SubscribedMessage",
    "UnsubscribeMessage",
    "UnsubscribedMessage",
    "ws_schema",
]

#: Close codes the server uses, and why (4xxx: the application's range, RFC 6455 §7.4.2).
CLOSE_CODES: dict[int, str] = {
    1001: "going away: the gateway shuts down",
    1011: "keepalive: the client answered no protocol ping for ws.ping_interval seconds",
    1012: "service restart: uvicorn closes every socket when the server stops",
    4401: "unauthorized: missing or unknown token (Authorization: Bearer, or ?token=)",
    4403: "forbidden: the token's role may not subscribe",
    4429: "too many failed authentications from this address: retry after the seconds the "
    "reason gives",
    4008: "backlog exceeded: the client did not read and its queue of unsent messages "
    "(ws.backlog) overflowed",
}

Topic = Annotated[str, Field(min_length=1, max_length=100, description=TOPIC_RULE)]
Seq = Annotated[int, Field(ge=0, description="the feed's message number")]
Time = Annotated[float, Field(description="wall clock, seconds since the epoch (UTC)")]


class _Client(BaseModel):
    model_config = ConfigDict(extra="forbid")


class SubscribeMessage(_Client):
    """Add topics. Answered with a ``snapshot`` of their resources, or, with ``since`` still
    in the replay buffer, the messages missed since then followed by ``subscribed``."""

    type: Literal["subscribe"]
    topics: list[Topic] = Field(min_length=1, max_length=1000)
    since: int | None = Field(
        None, ge=0, description="the last seq the client saw (resume after a reconnect)"
    )
    stream: str | None = Field(
        None,
        max_length=64,
        description="the stream of that seq (from snapshot/subscribed); another stream "
        "(the gateway restarted) means a snapshot",
    )


class UnsubscribeMessage(_Client):
    """Remove topics; answered with ``unsubscribed``."""

    type: Literal["unsubscribe"]
    topics: list[Topic] = Field(min_length=1, max_length=1000)


class PingMessage(_Client):
    """Answered with ``pong`` carrying the same ``id`` (after every message queued before)."""

    type: Literal["ping"]
    id: str | int | None = Field(None, description="echoed in the pong")


class ClientMessage(RootModel[SubscribeMessage | UnsubscribeMessage | PingMessage]):
    """Any message a client sends (JSON text frames)."""

    root: Annotated[
        SubscribeMessage | UnsubscribeMessage | PingMessage, Field(discriminator="type")
    ]


class _Server(BaseModel):
    seq: Seq
    time: Time


class SnapshotMessage(_Server):
    """The current views of the subscribed resources; changes with a greater ``seq`` follow."""

    type: Literal["snapshot"]
    topics: list[str] = Field(description="the topics it answers (ids for names)")
    stream: str
    loops: list[LoopView]
    controllers: list[ControllerView]
    axes: list[AxisView]


class SubscribedMessage(_Server):
    """After the ``replayed`` missed messages of ``topics``: the client is caught up."""

    type: Literal["subscribed"]
    topics: list[str]
    stream: str
    replayed: int = Field(ge=0)


class UnsubscribedMessage(_Server):
    """The topics no longer delivered."""

    type: Literal["unsubscribed"]
    topics: list[str]


class ChangeMessage(_Server):
    """A resource changed: its whole new view, and which of its fields changed."""

    type: Literal["change"]
    topic: str = Field(examples=["axis:main.1.2"])
    state_seq: int = Field(description="the state cache's change number")
    changed: list[str] = Field(description="top-level fields of `data` that changed")
    data: AxisView | ControllerView | LoopView


class EventMessage(_Server):
    """Something happened: an operation's progress, a device message, a link going down..."""

    type: Literal["event"]
    topic: str = Field(examples=["event:operation"])
    kind: EventKind
    resource: str = Field(description="the topic of the resource it is about")
    data: dict[str, Any]


class PongMessage(_Server):
    """The answer to ``ping``."""

    type: Literal["pong"]
    id: str | int | None = None


class ErrorMessage(_Server):
    """A client message was refused (the connection stays open)."""

    type: Literal["error"]
    field: str | None = Field(description="the field at fault, e.g. topics[0]; None: the frame")
    rule: str
    detail: str


_SERVER = (
    SnapshotMessage
    | SubscribedMessage
    | UnsubscribedMessage
    | ChangeMessage
    | EventMessage
    | PongMessage
    | ErrorMessage
)


class ServerMessage(RootModel[_SERVER]):
    """Any message the server sends (JSON text frames)."""

    root: Annotated[_SERVER, Field(discriminator="type")]


def ws_schema() -> dict[str, Any]:
    """JSON Schema (2020-12) of both directions: ``$defs.ClientMessage`` and
    ``$defs.ServerMessage``; close codes under ``x-close-codes``."""
    _, top = models_json_schema(
        [(ClientMessage, "validation"), (ServerMessage, "validation")],
        ref_template="#/$defs/{model}",
    )
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://rc233-gateway/openapi/ws.json",
        "title": "rc233-gateway WebSocket /api/v1/ws",
        "description": (
            "JSON text frames. Authenticate with 'Authorization: Bearer <token>' or "
            "'?token=<token>' (any role). Send subscribe/unsubscribe/ping (ClientMessage); "
            "receive ServerMessage. Every server message has seq (one counter for the whole "
            "feed; resume with subscribe.since) and time (seconds since the epoch). "
            "Keepalive: WebSocket protocol pings every ws.ping_interval seconds."
        ),
        "oneOf": [{"$ref": "#/$defs/ClientMessage"}, {"$ref": "#/$defs/ServerMessage"}],
        "$defs": top["$defs"],
        "x-close-codes": {str(code): why for code, why in CLOSE_CODES.items()},
        "x-topics": TOPIC_RULE,
    }
