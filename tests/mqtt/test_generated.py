"""gateway/mqtt/sparkplug_b_pb2.py(.pyi) are protoc's output for sparkplug_b.proto, now.

Regenerate (grpcio-tools is a test dependency, pinned in pyproject.toml):

    cd gateway/mqtt && ../../.venv/bin/python -m grpc_tools.protoc --proto_path=. \\
        --python_out=. --pyi_out=. sparkplug_b.proto
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from grpc_tools import protoc

MQTT = Path(__file__).resolve().parents[2] / "gateway" / "mqtt"
#: Eclipse Tahu's sparkplug_b/sparkplug_b.proto as vendored (a change must be deliberate)
PROTO_SHA256 = "4432c5c483b7fb9732d0594c98a2e97dca5e517e39c5374a8b918d837f0b4a19"


def test_the_proto_is_tahus_as_vendored() -> None:
    digest = hashlib.sha256((MQTT / "sparkplug_b.proto").read_bytes()).hexdigest()
    assert digest == PROTO_SHA256


def test_the_generated_code_is_not_stale(tmp_path: Path) -> None:
    (tmp_path / "sparkplug_b.proto").write_bytes((MQTT / "sparkplug_b.proto").read_bytes())
    status = protoc.main(
        [
            "grpc_tools.protoc",
            f"--proto_path={tmp_path}",
            f"--python_out={tmp_path}",
            f"--pyi_out={tmp_path}",
            str(tmp_path / "sparkplug_b.proto"),
        ]
    )
    assert status == 0
    for name in ("sparkplug_b_pb2.py", "sparkplug_b_pb2.pyi"):
        fresh = (tmp_path / name).read_text()
        assert (MQTT / name).read_text() == fresh, f"gateway/mqtt/{name} is stale: {__doc__}"
