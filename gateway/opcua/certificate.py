"""The server's certificate: made at the first start in the state directory (or by
``rc233-gateway opcua-cert``), with the application URI the clients check it against."""

from __future__ import annotations

import socket
from pathlib import Path

from asyncua.crypto.cert_gen import setup_self_signed_certificate
from cryptography.x509.oid import ExtendedKeyUsageOID

__all__ = ["CERT_NAME", "KEY_NAME", "ensure_certificate", "server_files"]

CERT_NAME = "opcua/server-cert.der"
KEY_NAME = "opcua/server-key.pem"


def server_files(state_dir: Path) -> tuple[Path, Path]:
    """Where the certificate and its key are kept in ``state_dir``."""
    return state_dir / CERT_NAME, state_dir / KEY_NAME


async def ensure_certificate(cert: Path, key: Path, application_uri: str) -> bool:
    """Make the certificate and key when missing or invalid; True when one was made."""
    before = cert.read_bytes() if cert.is_file() else None
    cert.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    host = socket.gethostname()
    await setup_self_signed_certificate(
        key,
        cert,
        application_uri,
        host,
        [ExtendedKeyUsageOID.SERVER_AUTH],
        {"commonName": f"rc233-gateway@{host}", "organizationName": "rc233-gateway"},
    )
    key.chmod(0o600)
    return before is None or before != cert.read_bytes()
