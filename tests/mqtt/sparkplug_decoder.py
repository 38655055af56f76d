"""A Sparkplug B payload decoder written for the tests, from the Tahu schema's field numbers.

It reads the protobuf wire format by hand (varints, fixed 32/64, length-delimited), so what
the tests check does not go through the gateway's generated code or the protobuf library:
an encoder bug there cannot hide behind the same bug here.

sparkplug_b.proto, ``Payload``: 1 timestamp, 2 metrics, 3 seq. ``Metric``: 1 name, 2 alias,
3 timestamp, 4 datatype, 5 is_historical, 7 is_null, 9 properties, 10 int_value (uint32),
11 long_value (uint64), 12 float_value, 13 double_value, 14 boolean_value, 15 string_value.
``PropertySet``: 1 keys, 2 values; ``PropertyValue``: 1 type, 2 is_null, 8 string_value.
DataType: Int32 3, Int64 4, UInt64 8, Double 10, Boolean 11, String 12.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any


def _varint(data: bytes, i: int) -> tuple[int, int]:
    shift = result = 0
    while True:
        byte = data[i]
        i += 1
        result |= (byte & 0x7F) << shift
        if not byte & 0x80:
            return result, i
        shift += 7


def _fields(data: bytes) -> Iterator[tuple[int, int, Any]]:
    """(field number, wire type, raw value) of each field of one message."""
    i = 0
    while i < len(data):
        key, i = _varint(data, i)
        number, wire = key >> 3, key & 7
        if wire == 0:
            value, i = _varint(data, i)
        elif wire == 1:
            value, i = data[i : i + 8], i + 8
        elif wire == 2:
            length, i = _varint(data, i)
            value, i = data[i : i + length], i + length
        elif wire == 5:
            value, i = data[i : i + 4], i + 4
        else:
            raise ValueError(f"wire type {wire} of field {number}")
        yield number, wire, value


@dataclass
class Metric:
    """One decoded metric."""

    name: str | None = None
    alias: int | None = None
    timestamp: int | None = None
    datatype: int | None = None
    is_null: bool = False
    is_historical: bool = False
    value: Any = None
    properties: dict[str, str] = field(default_factory=dict)


@dataclass
class Payload:
    """One decoded payload."""

    timestamp: int | None = None
    seq: int | None = None
    metrics: list[Metric] = field(default_factory=list)


def _signed(value: int, bits: int) -> int:
    return value - (1 << bits) if value >= 1 << (bits - 1) else value


def _properties(data: bytes) -> dict[str, str]:
    keys: list[str] = []
    values: list[str] = []
    for number, _, raw in _fields(data):
        if number == 1:
            keys.append(raw.decode())
        elif number == 2:
            text = ""
            for n, _, r in _fields(raw):
                if n == 8:
                    text = r.decode()
            values.append(text)
    return dict(zip(keys, values, strict=True))


def _metric(data: bytes) -> Metric:
    m = Metric()
    raw_value: tuple[int, Any] | None = None
    for number, _, raw in _fields(data):
        if number == 1:
            m.name = raw.decode()
        elif number == 2:
            m.alias = raw
        elif number == 3:
            m.timestamp = raw
        elif number == 4:
            m.datatype = raw
        elif number == 5:
            m.is_historical = bool(raw)
        elif number == 7:
            m.is_null = bool(raw)
        elif number == 9:
            m.properties = _properties(raw)
        elif 10 <= number <= 15:
            raw_value = (number, raw)
    if raw_value is not None and not m.is_null:
        number, raw = raw_value
        if number == 10:
            m.value = _signed(raw, 32) if m.datatype == 3 else raw
        elif number == 11:
            m.value = _signed(raw, 64) if m.datatype == 4 else raw
        elif number == 12:
            m.value = struct.unpack("<f", raw)[0]
        elif number == 13:
            m.value = struct.unpack("<d", raw)[0]
        elif number == 14:
            m.value = bool(raw)
        else:
            m.value = raw.decode()
    return m


def decode(data: bytes) -> Payload:
    """A Sparkplug B payload."""
    p = Payload()
    for number, _, raw in _fields(data):
        if number == 1:
            p.timestamp = raw
        elif number == 2:
            p.metrics.append(_metric(raw))
        elif number == 3:
            p.seq = raw
    return p


def _key(number: int, wire: int) -> bytes:
    return _put_varint(number << 3 | wire)


def _put_varint(value: int) -> bytes:
    out = bytearray()
    while True:
        byte = value & 0x7F
        value >>= 7
        if value:
            out.append(byte | 0x80)
        else:
            out.append(byte)
            return bytes(out)


def _ld(number: int, data: bytes) -> bytes:
    return _key(number, 2) + _put_varint(len(data)) + data


def command(timestamp: int, metrics: dict[str, bool | str]) -> bytes:
    """An NCMD/DCMD payload written by hand: each metric by name, Boolean or String."""
    out = _key(1, 0) + _put_varint(timestamp)
    for name, value in metrics.items():
        body = _ld(1, name.encode()) + _key(3, 0) + _put_varint(timestamp)
        if isinstance(value, bool):
            body += _key(4, 0) + _put_varint(11) + _key(14, 0) + _put_varint(int(value))
        else:
            body += _key(4, 0) + _put_varint(12) + _ld(15, value.encode())
        out += _ld(2, body)
    return out
