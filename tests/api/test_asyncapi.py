"""openapi/asyncapi.json: valid for the AsyncAPI parser, and true to the messages on the wire.

The parser is npm's @asyncapi/parser, installed by `make test` into tools/asyncapi
(`npm ci`). Every message the WebSocket tests receive is checked against the document
(tests/support/ws_server.py, ``check_server_message``); here a real `serve --simulate` feed is
read from subscribe to a pong, and a client message the document does not allow is refused.
"""

from __future__ import annotations

import asyncio
import json
import shutil
import subprocess
from pathlib import Path
from typing import Any

import jsonschema_rs
from websockets.asyncio.client import connect

from gateway.api.ws.asyncapi import asyncapi_document, json_schema_of
from tests.support.serve_process import serve
from tests.support.ws_server import check_server_message

ROOT = Path(__file__).parents[2]
TOOLS = ROOT / "tools" / "asyncapi"
DOCUMENT = ROOT / "openapi" / "asyncapi.json"


def _validate(*paths: Path) -> subprocess.CompletedProcess[str]:
    node = shutil.which("node")
    assert node, "Node.js is not installed: `apt-get install nodejs npm` (`make test` does it)"
    assert (TOOLS / "node_modules" / "@asyncapi" / "parser").is_dir(), (
        "the AsyncAPI parser is not installed: `cd tools/asyncapi && npm ci` (`make test` does it)"
    )
    return subprocess.run(
        [node, str(TOOLS / "validate.mjs"), *map(str, paths)],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip


def test_the_asyncapi_parser_accepts_the_document(tmp_path: Path) -> None:
    """The published document passes; the same with pydantic's OpenAPI-style discriminator
    object (what it would hold had the schemas been copied as they are) is refused, so the
    parser does check the schemas. One parser process for both (it is slow to start)."""
    broken: dict[str, Any] = json.loads(DOCUMENT.read_text())
    snapshot = broken["components"]["schemas"]["SnapshotMessage"]
    snapshot["discriminator"] = {"propertyName": "type", "mapping": {}}
    (tmp_path / "broken.json").write_text(json.dumps(broken))
    done = _validate(DOCUMENT, tmp_path / "broken.json")
    lines = [json.loads(line) for line in done.stdout.splitlines()]
    summaries = {Path(line["file"]).name: line for line in lines if "valid" in line}
    assert summaries["asyncapi.json"]["valid"] is True, done.stdout + done.stderr
    assert summaries["asyncapi.json"]["version"] == "3.0.0"
    assert summaries["asyncapi.json"]["messages"] == 10
    assert summaries["broken.json"]["valid"] is False, done.stdout
    assert done.returncode == 1
    refusals = [line for line in lines if line["file"].endswith("broken.json") and "code" in line]
    assert any("discriminator" in line["path"] for line in refusals), refusals


async def test_messages_from_a_running_gateway_fit_the_document(tmp_path: Path) -> None:
    document = asyncapi_document()
    received = jsonschema_rs.validator_for(json_schema_of(document, "receive"))
    subscribe = {"type": "subscribe", "topics": ["axis:x", "loop:sim", "events"]}
    assert received.is_valid(subscribe)
    assert not received.is_valid({"type": "subscribe", "topics": "axis:x"})
    async with serve(tmp_path) as server:
        url = server.url.replace("http://", "ws://") + "/api/v1/ws"
        async with connect(url, compression=None) as ws:
            await ws.send(json.dumps(subscribe))
            snapshot = check_server_message(await asyncio.wait_for(ws.recv(), 10))
            assert snapshot["type"] == "snapshot"
            await ws.send(json.dumps({"type": "ping", "id": 7}))
            kinds = [snapshot["type"]]
            while kinds[-1] != "pong":  # changes of the polled axis may come first
                kinds.append(check_server_message(await asyncio.wait_for(ws.recv(), 10))["type"])
            await ws.send(json.dumps({"type": "subscribe", "topics": []}))
            while kinds[-1] != "error":
                kinds.append(check_server_message(await asyncio.wait_for(ws.recv(), 10))["type"])
    assert kinds[0] == "snapshot" and "pong" in kinds and kinds[-1] == "error"
