"""The MQTT client of the edge node: MQTT 5, the NDEATH as will, TLS and login.

MQTT 5 for what it tells: the no-local subscription option (an NBIRTH on the node's own topic
that comes back is another node's, gateway/mqtt/session_guard.py) and, on brokers that send
it, the reason of a disconnection ("Session taken over").
"""

from __future__ import annotations

import asyncio
import ssl

import aiomqtt

from gateway.service.config import MqttSettings

__all__ = ["broker_client", "client_id"]


def client_id(settings: MqttSettings) -> str:
    """The configured client id, or ``rc233-<group>-<edge_node>``."""
    return settings.client_id or f"rc233-{settings.group}-{settings.edge_node}"


async def broker_client(
    settings: MqttSettings, identifier: str, will: tuple[str, bytes]
) -> aiomqtt.Client:
    """A client for ``settings`` (not connected yet) whose will is ``will`` (topic, payload),
    QoS 1, not retained, with a clean start (Sparkplug 3.0)."""
    s = settings
    tls: ssl.SSLContext | None = None
    if s.tls:
        tls = await asyncio.to_thread(_tls_context, s)
    return aiomqtt.Client(
        s.host,
        s.port,
        identifier=identifier,
        username=s.username,
        password=s.password.get_secret_value() if s.password else None,
        keepalive=s.keepalive,
        tls_context=tls,
        will=aiomqtt.Will(will[0], will[1], qos=1, retain=False),
        protocol=aiomqtt.ProtocolVersion.V5,
        clean_start=True,
    )


def _tls_context(settings: MqttSettings) -> ssl.SSLContext:
    """The TLS context of the broker connection (files read here, in a worker thread)."""
    context = ssl.create_default_context(cafile=str(settings.ca_file) if settings.ca_file else None)
    if settings.cert_file and settings.key_file:
        context.load_cert_chain(str(settings.cert_file), str(settings.key_file))
    return context
