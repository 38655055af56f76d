"""openapi/ holds the generated documents; they must be what the app generates now.

Regenerate with `.venv/bin/rc233-gateway openapi` (writes openapi/openapi.json,
openapi/websocket.json and openapi/asyncapi.json).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from gateway.cli import main
from gateway.cli.documents import documents, render

OPENAPI_DIR = Path(__file__).parents[2] / "openapi"
#: Generated once for the module: the document of ~240 command models takes a while.
DOCUMENTS = documents()


@pytest.mark.parametrize("name", sorted(DOCUMENTS))
def test_the_published_document_is_up_to_date(name: str) -> None:
    published = (OPENAPI_DIR / name).read_text(encoding="utf-8")
    assert published == render(DOCUMENTS[name]), (
        f"openapi/{name} is stale: run `.venv/bin/rc233-gateway openapi`"
    )


def test_the_command_writes_both_documents(tmp_path: Path) -> None:
    assert main(["openapi", "--out", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "asyncapi.json", "openapi.json", "websocket.json",
    ]  # fmt: skip
    for path in tmp_path.iterdir():
        assert path.read_text(encoding="utf-8") == render(DOCUMENTS[path.name])


def test_the_openapi_document_describes_the_api_a_user_calls() -> None:
    document = DOCUMENTS["openapi.json"]
    assert document["openapi"].startswith("3.")
    paths = document["paths"]
    for path in ("/api/v1/axes", "/api/v1/axes/{id}/move", "/api/v1/controllers/{id}/commands"):
        assert path in paths
    move = paths["/api/v1/axes/{id}/move"]["post"]
    assert "202" in move["responses"] and "422" in move["responses"]
    problem = move["responses"]["422"]["content"]
    assert list(problem) == ["application/problem+json"]
