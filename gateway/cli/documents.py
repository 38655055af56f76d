"""``rc233-gateway openapi`` and ``token``: the published API documents, and token hashes.

The OpenAPI document and the WebSocket message schema are generated from the app itself, so
they cannot drift from it; ``openapi/`` holds the generated files and a test fails when they
are stale (tests/api/test_openapi_files.py).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from gateway.api.app import create_app
from gateway.api.security import AuthConfig, TokenBook, hash_token, new_token
from gateway.api.ws.asyncapi import asyncapi_document
from gateway.api.ws.messages import ws_schema
from gateway.compose import compose
from gateway.service.runtime.runtime import Runtime
from gateway.service.runtime.simulated import simulated_config

__all__ = ["add_document_parsers", "documents", "render"]

OPENAPI_FILE = "openapi.json"
WS_FILE = "websocket.json"
ASYNCAPI_FILE = "asyncapi.json"


def documents() -> dict[str, dict[str, Any]]:
    """File name -> document: the OpenAPI document, the WebSocket message schema and the
    WebSocket's AsyncAPI document."""
    # never started: building a Runtime starts no worker and opens no line
    runtime = Runtime(simulated_config())
    app = create_app(compose(runtime), auth=AuthConfig(TokenBook()))
    return {OPENAPI_FILE: app.openapi(), WS_FILE: ws_schema(), ASYNCAPI_FILE: asyncapi_document()}


def render(document: dict[str, Any]) -> str:
    """The text a document is stored as (stable: sorted keys, 2 spaces, final newline)."""
    return json.dumps(document, indent=2, sort_keys=True, ensure_ascii=False) + "\n"


def _openapi(args: argparse.Namespace) -> int:
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    for name, document in documents().items():
        (out / name).write_text(render(document), encoding="utf-8")
        print(f"wrote {out / name}")
    return 0


def _token(args: argparse.Namespace) -> int:
    token = args.token or new_token()
    print(f"token:  {token}")
    print("config: [[security.tokens]]")
    print(f'        name = "{args.name}"')
    print(f'        role = "{args.role}"')
    print(f'        sha256 = "{hash_token(token)}"')
    return 0


def add_document_parsers(subparsers: Any) -> None:
    """Add ``openapi`` and ``token`` to the subcommands."""
    doc = subparsers.add_parser(
        "openapi", help="write openapi/openapi.json, websocket.json and asyncapi.json"
    )
    doc.add_argument("--out", type=Path, default=Path("openapi"), help="default ./openapi")
    doc.set_defaults(func=_openapi)
    tok = subparsers.add_parser("token", help="make an API token and its configuration lines")
    tok.add_argument("--name", default="mes", help="the name the audit log shows")
    tok.add_argument("--role", choices=["viewer", "operator", "admin"], default="operator")
    tok.add_argument("--token", help="hash this token instead of making a new one")
    tok.set_defaults(func=_token)
