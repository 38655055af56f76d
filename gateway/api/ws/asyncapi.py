"""The AsyncAPI 3.0 document of the WebSocket ``/api/v1/ws`` (``openapi/asyncapi.json``).

Generated from the same pydantic models as ``websocket.json`` (``ws_messages``), so the two
cannot drift. AsyncAPI's schema language is JSON Schema (draft 7) with a ``discriminator``
that is a property name, not OpenAPI's object: pydantic's ``discriminator`` objects are
dropped (every message's ``type`` is a ``const``, so the ``oneOf`` stays exact) and the
``$defs`` references are moved under ``components/schemas``.

Operations are written from the gateway's side, as AsyncAPI 3.0 wants: the gateway
*receives* subscribe, unsubscribe and ping, and *sends* everything else. ``make test``
validates the document with the AsyncAPI parser (tools/asyncapi), and the WebSocket tests
check every message they receive against it.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel

from gateway import __version__
from gateway.api.ws.messages import (
    CLOSE_CODES,
    ChangeMessage,
    ErrorMessage,
    EventMessage,
    PingMessage,
    PongMessage,
    SnapshotMessage,
    SubscribedMessage,
    SubscribeMessage,
    UnsubscribedMessage,
    UnsubscribeMessage,
    ws_schema,
)

__all__ = ["CLIENT_MESSAGES", "SERVER_MESSAGES", "asyncapi_document", "json_schema_of"]

CHANNEL = "feed"
CLIENT_MESSAGES: tuple[type[BaseModel], ...] = (SubscribeMessage, UnsubscribeMessage, PingMessage)
SERVER_MESSAGES: tuple[type[BaseModel], ...] = (
    SnapshotMessage,
    SubscribedMessage,
    UnsubscribedMessage,
    ChangeMessage,
    EventMessage,
    PongMessage,
    ErrorMessage,
)


def _plain(node: Any) -> Any:
    """``node`` with ``$defs`` references under components/schemas, no discriminator objects."""
    if isinstance(node, dict):
        out = {}
        for key, value in node.items():
            if key == "discriminator" and isinstance(value, dict):
                continue
            if key == "$ref" and isinstance(value, str):
                value = value.replace("#/$defs/", "#/components/schemas/")
            out[key] = _plain(value)
        return out
    if isinstance(node, list):
        return [_plain(item) for item in node]
    return node


def _name(model: type[BaseModel]) -> str:
    """The message's ``type``: ``SubscribeMessage`` -> ``subscribe``."""
    values: tuple[object, ...] = getattr(model.model_fields["type"].annotation, "__args__", ())
    assert len(values) == 1, model
    return str(values[0])


def _message(model: type[BaseModel]) -> dict[str, Any]:
    return {
        "name": _name(model),
        "title": model.__name__,
        "summary": (model.__doc__ or "").strip().split("\n")[0],
        "contentType": "application/json",
        "payload": {"$ref": f"#/components/schemas/{model.__name__}"},
    }


def _operation(action: str, model: type[BaseModel]) -> dict[str, Any]:
    return {
        "action": action,
        "channel": {"$ref": f"#/channels/{CHANNEL}"},
        "summary": (model.__doc__ or "").strip().split("\n")[0],
        "messages": [{"$ref": f"#/channels/{CHANNEL}/messages/{_name(model)}"}],
    }


def asyncapi_document() -> dict[str, Any]:
    """The AsyncAPI 3.0 document (see the module)."""
    legacy = ws_schema()
    models = CLIENT_MESSAGES + SERVER_MESSAGES
    verbs = {"receive": CLIENT_MESSAGES, "send": SERVER_MESSAGES}
    close_codes = "; ".join(f"{code} {why}" for code, why in CLOSE_CODES.items())
    return {
        "asyncapi": "3.0.0",
        "info": {
            "title": "rc233-gateway WebSocket",
            "version": __version__,
            "description": f"{legacy['description']} Close codes: {close_codes}. "
            f"Topics: {legacy['x-topics']}",
        },
        "defaultContentType": "application/json",
        "servers": {
            "gateway": {
                "host": "127.0.0.1:8233",
                "protocol": "ws",
                "description": "`rc233-gateway serve` (wss behind a TLS proxy on a site)",
                "security": [{"$ref": "#/components/securitySchemes/bearer"}],
            }
        },
        "channels": {
            CHANNEL: {
                "address": "/api/v1/ws",
                "title": "The gateway's feed",
                "description": "Every message is one JSON text frame.",
                "messages": {
                    _name(m): {"$ref": f"#/components/messages/{_name(m)}"} for m in models
                },
            }
        },
        "operations": {
            f"{action}{_name(m).capitalize()}": _operation(action, m)
            for action, group in verbs.items()
            for m in group
        },
        "components": {
            "schemas": _plain(legacy["$defs"]),
            "messages": {_name(m): _message(m) for m in models},
            "securitySchemes": {
                "bearer": {
                    "type": "http",
                    "scheme": "bearer",
                    "description": "An API token (any role): `Authorization: Bearer <token>` "
                    "or `?token=<token>` in the URL",
                }
            },
        },
    }


def json_schema_of(document: dict[str, Any], direction: str = "send") -> dict[str, Any]:
    """A JSON Schema (draft 7) matching exactly the messages the gateway ``send``s (or
    ``receive``s) according to ``document``, for validating messages seen on the wire."""
    refs = [
        message["$ref"]
        for operation in document["operations"].values()
        if operation["action"] == direction
        for message in operation["messages"]
    ]
    payloads = []
    for ref in refs:
        name = ref.rsplit("/", 1)[1]
        payloads.append(document["components"]["messages"][name]["payload"])
    return {
        "$schema": "http://json-schema.org/draft-07/schema#",
        "oneOf": payloads,
        "components": {"schemas": document["components"]["schemas"]},
    }
