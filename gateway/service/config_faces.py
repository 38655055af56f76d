"""The sections of the optional faces: the Sparkplug B edge node (``[mqtt]``) and the OPC UA
server (``[opcua]``). Each face is off unless its section is present."""

from __future__ import annotations

from pathlib import Path
from typing import Literal, Self

from pydantic import Field, SecretStr, model_validator

from gateway.service.config_base import Strict

__all__ = ["MqttSettings", "OpcUaPolicy", "OpcUaSettings"]


class MqttSettings(Strict):
    """The Sparkplug B edge node (gateway/mqtt): off unless the section is present.

    ``group`` and ``edge_node`` are Sparkplug ids: no ``+``, ``/`` or ``#`` (MQTT wildcards
    and the topic separator). ``password`` is a secret: never logged, never shown.
    """

    host: str = Field(min_length=1)
    port: int = Field(1883, ge=1, le=65535)
    group: str = Field(pattern=r"^[^+/#\s]{1,64}$")
    edge_node: str = Field(pattern=r"^[^+/#\s]{1,64}$")
    #: the MQTT client id; default ``rc233-<group>-<edge_node>``
    client_id: str | None = Field(None, min_length=1, max_length=64)
    username: str | None = None
    password: SecretStr | None = None
    #: TLS to the broker: the CA bundle that signs its certificate (system CAs when omitted)
    tls: bool = False
    ca_file: Path | None = None
    cert_file: Path | None = None
    key_file: Path | None = None
    keepalive: int = Field(30, ge=5, le=3600, description="seconds")
    #: DCMD stop and acknowledge; off by default (commands then only over the REST API)
    commands: bool = False
    #: reconnect back-off: first and longest wait in seconds
    reconnect_min: float = Field(0.5, gt=0, le=60)
    reconnect_max: float = Field(30.0, gt=0, le=600)
    #: bytes; a received payload over this is dropped before it is decoded (counted, logged)
    max_payload: int = Field(65_536, ge=1_024, le=16_777_216)
    #: the Sparkplug 3.0 Primary Host Application's id: births wait for its STATE online
    primary_host: str | None = Field(None, pattern=r"^[^+/#\s]{1,64}$")

    @model_validator(mode="after")
    def _tls_files(self) -> Self:
        if not self.tls and (self.ca_file or self.cert_file or self.key_file):
            raise ValueError("ca_file, cert_file and key_file need tls = true")
        if (self.cert_file is None) != (self.key_file is None):
            raise ValueError("cert_file and key_file go together (client certificate)")
        return self


#: The security policies the OPC UA face offers: a policy and its message security mode.
OpcUaPolicy = Literal[
    "None",
    "Basic256Sha256_Sign",
    "Basic256Sha256_SignAndEncrypt",
    "Aes256Sha256RsaPss_Sign",
    "Aes256Sha256RsaPss_SignAndEncrypt",
]


class OpcUaSettings(Strict):
    """The OPC UA server face (gateway/opcua): off unless the section is present.

    Users log in with a token name as user name and the token itself as password (the
    ``security.tokens`` book and its roles). ``certificate`` and ``private_key`` default to
    files in the state directory, made at the first start (``rc233-gateway opcua-cert``).
    """

    endpoint: str = Field("opc.tcp://0.0.0.0:4840", pattern=r"^opc\.tcp://[^/:\s]+:\d{1,5}(/\S*)?$")
    security_policies: list[OpcUaPolicy] = Field(
        default_factory=lambda: [  # type: ignore[arg-type]
            "Basic256Sha256_SignAndEncrypt",
            "Basic256Sha256_Sign",
            "Aes256Sha256RsaPss_SignAndEncrypt",
            "Aes256Sha256RsaPss_Sign",
        ],
        min_length=1,
    )
    #: sessions without a user; they are viewers (browse, read, subscribe, no method)
    anonymous: bool = False
    #: the application URI, also in the server certificate
    application_uri: str = Field("urn:rc233-gateway", min_length=1, max_length=256)
    certificate: Path | None = None
    private_key: Path | None = None
    #: a folder of trusted client certificates (DER or PEM); None: any client certificate
    trusted_clients: Path | None = None

    @model_validator(mode="after")
    def _checks(self) -> Self:
        port = int(self.endpoint.rsplit(":", 1)[1].split("/")[0])
        if not 1 <= port <= 65535:
            raise ValueError(f"endpoint {self.endpoint}: port {port} is not 1-65535")
        if len(set(self.security_policies)) != len(self.security_policies):
            raise ValueError("security_policies: each policy once")
        if (self.certificate is None) != (self.private_key is None):
            raise ValueError("certificate and private_key go together")
        return self
