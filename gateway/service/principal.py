"""Who asks: the one principal type of every face (REST, WebSocket, MQTT, OPC UA).

A face turns what its caller presents (a bearer token, a DCMD's ``Command/Token`` metric, an
OPC UA session's user name and password) into a ``Principal`` through an ``Identify`` it is
given (the token book of the configuration); service/ checks the principal's role and
records its name (leases, operations, the audit record). It lives here, below the faces,
because the faces may not import each other.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from gateway.service.roles import Role

__all__ = ["Identify", "Principal"]


@dataclass(frozen=True)
class Principal:
    """Who made a request: the token's name, its role, and the client's address (or the
    face's name where there is no address: ``mqtt``, ``opcua``)."""

    name: str
    role: Role
    client: str


#: The principal of a token presented by ``client`` (token, client); None: unknown token.
Identify = Callable[[str, str], Principal | None]
