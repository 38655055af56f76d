"""``rc233-gateway opcua-cert --config FILE``: the OPC UA server's certificate, made now.

``serve`` makes it at its first start when the file is missing; this makes it beforehand (to
hand its thumbprint to the clients' trust lists) or again with ``--renew``. It goes where
``serve`` looks: ``opcua.certificate`` / ``opcua.private_key`` when the file names them, else
``opcua/`` in the state directory. The application URI is ``opcua.application_uri``.
"""

from __future__ import annotations

import argparse
import asyncio
import hashlib
import sys
from pathlib import Path
from typing import Any

from gateway.opcua.certificate import ensure_certificate, server_files
from gateway.service.config import ConfigError, load_config
from gateway.service.store import default_state_dir

__all__ = ["add_opcua_cert_parser"]


def _main(args: argparse.Namespace) -> int:
    try:
        config = load_config(args.config)
    except ConfigError as exc:
        print(f"rc233-gateway opcua-cert: {exc}", file=sys.stderr)
        return 2
    if config.opcua is None:
        print(f"rc233-gateway opcua-cert: {args.config}: no [opcua] section", file=sys.stderr)
        return 2
    opcua = config.opcua
    cert, key = opcua.certificate, opcua.private_key
    if cert is None or key is None:
        cert, key = server_files(config.state_dir or default_state_dir())
    if args.renew:
        for path in (cert, key):
            Path(path).unlink(missing_ok=True)
    made = asyncio.run(ensure_certificate(cert, key, opcua.application_uri))
    thumbprint = hashlib.sha1(cert.read_bytes()).hexdigest()  # OPC UA's thumbprint is SHA-1
    print(f"{'made' if made else 'kept'} {cert} (key {key})")
    print(f"application URI {opcua.application_uri}; SHA-1 thumbprint {thumbprint}")
    return 0


def add_opcua_cert_parser(subparsers: Any) -> None:
    """Add ``opcua-cert`` to the subcommands of ``rc233-gateway``."""
    parser = subparsers.add_parser(
        "opcua-cert",
        help="make the OPC UA server's certificate",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--config", type=Path, required=True, metavar="FILE")
    parser.add_argument("--renew", action="store_true", help="a new key and certificate")
    parser.set_defaults(func=_main)
