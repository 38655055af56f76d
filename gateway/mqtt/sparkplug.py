"""Sparkplug B 3.0 on the wire: topics, data types, and payloads encoded with the Tahu schema.

The payload is ``org.eclipse.tahu.protobuf.Payload`` from Eclipse Tahu's
``sparkplug_b.proto`` (vendored beside this module, compiled to ``sparkplug_b_pb2``; a test
fails when the generated code no longer matches the .proto or the protobuf compiler).

A metric whose value the gateway does not know (loop down, controller offline, data stale)
is sent with ``is_null`` set and no value: the Sparkplug way of saying "no value", never the
last good number.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from enum import IntEnum, StrEnum

from gateway.mqtt import sparkplug_b_pb2 as pb

__all__ = [
    "NAMESPACE",
    "DataType",
    "Message",
    "Metric",
    "Value",
    "decode_commands",
    "encode",
    "topic",
]

NAMESPACE = "spBv1.0"

#: A metric's value: None is "not known" (``is_null``).
Value = bool | int | float | str | None


class Message(StrEnum):
    """The Sparkplug message types an edge node sends or receives."""

    NBIRTH = "NBIRTH"
    NDATA = "NDATA"
    NDEATH = "NDEATH"
    DBIRTH = "DBIRTH"
    DDATA = "DDATA"
    DDEATH = "DDEATH"
    NCMD = "NCMD"
    DCMD = "DCMD"


class DataType(IntEnum):
    """The Sparkplug data types used here (``DataType`` of sparkplug_b.proto)."""

    INT32 = 3
    INT64 = 4
    UINT64 = 8
    DOUBLE = 10
    BOOLEAN = 11
    STRING = 12


@dataclass(frozen=True, slots=True)
class Metric:
    """One metric as sent: its name (births), alias, type, value and timestamp (ms)."""

    name: str
    alias: int
    datatype: DataType
    value: Value
    timestamp: int
    #: properties sent in births (``engUnit``: the unit of a user-unit position)
    properties: Mapping[str, str] | None = None


def topic(group: str, message: Message, node: str, device: str | None = None) -> str:
    """``spBv1.0/{group}/{message}/{node}[/{device}]``."""
    base = f"{NAMESPACE}/{group}/{message.value}/{node}"
    return base if device is None else f"{base}/{device}"


def _set_value(out: pb.Payload.Metric, datatype: DataType, value: Value) -> None:
    if value is None:
        out.is_null = True
    elif datatype is DataType.BOOLEAN:
        out.boolean_value = bool(value)
    elif datatype is DataType.STRING:
        out.string_value = str(value)
    elif datatype is DataType.DOUBLE:
        out.double_value = float(value)
    elif datatype is DataType.INT32:
        # Sparkplug carries signed 32-bit values in the uint32 field, two's complement.
        out.int_value = int(value) & 0xFFFF_FFFF
    else:  # INT64, UINT64: the uint64 field, two's complement for negatives
        out.long_value = int(value) & 0xFFFF_FFFF_FFFF_FFFF


def encode(
    metrics: Iterable[Metric], *, timestamp: int, seq: int | None, birth: bool = False
) -> bytes:
    """A payload: births carry names, aliases, types and properties; data carries aliases."""
    payload = pb.Payload(timestamp=timestamp)
    if seq is not None:
        payload.seq = seq
    for metric in metrics:
        out = payload.metrics.add()
        if birth or metric.alias == 0:
            out.name = metric.name
        if metric.alias:
            out.alias = metric.alias
        out.timestamp = metric.timestamp
        out.datatype = int(metric.datatype)
        _set_value(out, metric.datatype, metric.value)
        if birth and metric.properties:
            for key, text in metric.properties.items():
                out.properties.keys.append(key)
                out.properties.values.add(type=int(DataType.STRING), string_value=text)
    data: bytes = payload.SerializeToString()
    return data


def _value_of(metric: pb.Payload.Metric) -> Value:
    if metric.is_null:
        return None
    kind = metric.WhichOneof("value")
    if kind is None:
        return None
    value: Value = getattr(metric, kind)
    return value


def decode_commands(data: bytes, names: Mapping[int, str]) -> dict[str, Value]:
    """The metrics of an NCMD or DCMD payload by name (an alias is looked up in ``names``);
    ``ValueError`` when the payload is not a Sparkplug payload."""
    payload = pb.Payload()
    try:
        payload.ParseFromString(data)
    except Exception as exc:  # protobuf's DecodeError; any failure means "not a payload"
        raise ValueError(f"not a Sparkplug B payload: {exc}") from None
    out: dict[str, Value] = {}
    for metric in payload.metrics:
        name = metric.name or names.get(metric.alias, "")
        if name:
            out[name] = _value_of(metric)
    return out
