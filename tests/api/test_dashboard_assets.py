"""The dashboard's files: vendored assets match their manifest, the app serves them with a
content security policy and cache headers, the docs work without a CDN, the session route.

``scripts/vendor_assets.py`` wrote the vendored files from ``npm pack`` of pinned versions and
recorded each file's SHA-256; a file edited by hand, truncated or left over fails here.
"""

from __future__ import annotations

import base64
import hashlib
import json
import re

from gateway.api.dashboard import EMPTY_TEXT_HASH, STATIC_DIR
from tests.support.sim_app import auth, json_of, running_app

VENDOR = STATIC_DIR / "vendor"


def test_every_vendored_file_has_the_hash_the_manifest_records() -> None:
    manifest = json.loads((VENDOR / "manifest.json").read_text())
    listed = set()
    for package in manifest["packages"]:
        assert re.fullmatch(r"\d+\.\d+\.\d+", package["version"]), package
        assert package["integrity"].startswith("sha512-")
        for entry in package["files"]:
            data = (VENDOR / entry["path"]).read_bytes()
            assert hashlib.sha256(data).hexdigest() == entry["sha256"], entry["path"]
            listed.add(entry["path"])
    present = {str(p.relative_to(VENDOR)) for p in VENDOR.rglob("*") if p.is_file()} - {
        "manifest.json"
    }
    assert present == listed, f"not in the manifest: {present - listed}"
    names = {p["name"] for p in manifest["packages"]}
    assert {"htm", "uplot", "swagger-ui-dist", "redoc"} <= names


def test_the_page_and_the_docs_load_nothing_from_another_host() -> None:
    for page in ("index.html", "docs.html", "redoc.html"):
        html = (STATIC_DIR / page).read_text()
        assert not re.search(r"(src|href)=\"(https?:)?//", html), page
        assert "<script>" not in html  # no inline script: the CSP forbids it
    for script in (STATIC_DIR / "js").glob("*.js"):
        assert not re.search(r"from \"(https?:)?//", script.read_text()), script.name


async def test_dashboard_docs_and_static_files_are_served_with_csp_and_cache_headers() -> None:
    async with running_app() as api:
        root = api.client.base_url.join("/")
        page = await api.client.get(root)
        assert page.status_code == 200 and "text/html" in page.headers["content-type"]
        assert page.headers["cache-control"] == "no-cache"
        csp = page.headers["content-security-policy"]
        assert "default-src 'self'" in csp and "script-src 'self'" in csp
        assert "unsafe-inline" not in csp and "unsafe-eval" not in csp
        assert page.headers["x-content-type-options"] == "nosniff"
        docs = await api.client.get("/docs")
        assert docs.status_code == 200 and "/static/vendor/swagger-ui/" in docs.text
        assert "content-security-policy" in docs.headers
        # ReDoc: the vendored bundle, the same policy but for the empty <style> element its
        # styled-components fills through the CSSOM, and its data: icon font
        redoc = await api.client.get("/redoc")
        assert redoc.status_code == 200 and "/static/vendor/redoc/" in redoc.text
        assert redoc.headers["cache-control"] == "no-cache"
        policy = redoc.headers["content-security-policy"]
        assert "script-src 'self';" in policy and "default-src 'self';" in policy
        assert "unsafe-inline" not in policy and "unsafe-eval" not in policy
        assert f"style-src 'self' {EMPTY_TEXT_HASH};" in policy
        empty = base64.b64encode(hashlib.sha256(b"").digest()).decode()
        assert f"'sha256-{empty}'" == EMPTY_TEXT_HASH  # admits an empty <style> and no other
        assert "connect-src 'self';" in policy and "frame-ancestors 'none'" in policy
        vendored = await api.client.get(root.join("/static/vendor/uplot/uPlot.esm.js"))
        assert vendored.status_code == 200
        assert vendored.headers["cache-control"].startswith("public, max-age=")
        own = await api.client.get(root.join("/static/js/app.js"))
        etag = own.headers["etag"]
        again = await api.client.get(
            root.join("/static/js/app.js"), headers={"If-None-Match": etag}
        )
        assert again.status_code == 304
        missing = await api.client.get(root.join("/static/nothing.js"))
        assert missing.status_code == 404
        up = await api.client.get(root.join("/static/../pyproject.toml"))
        assert up.status_code == 404
        api_root = await api.client.get(root.join("/api/v1"))
        assert api_root.status_code == 307 and api_root.headers["location"] == "/api/v1/docs"


async def test_the_session_says_who_the_caller_is() -> None:
    async with running_app() as api:
        assert json_of(await api.client.get("/session")) == {
            "name": "anonymous",
            "role": "admin",
            "authentication": False,
        }
    async with running_app(roles=True) as api:
        assert (await api.client.get("/session")).status_code == 401
        r = await api.client.get("/session", headers=auth("viewer"))
        assert json_of(r) == {"name": "viewer", "role": "viewer", "authentication": True}


async def test_a_program_is_checked_without_anything_sent() -> None:
    async with running_app() as api:
        mark = api.mark()
        ok = await api.client.post("/programs/check", json={"text": "/D00/0/END"})
        assert json_of(ok) == {"steps": 3, "bytes": 10}
        bad = await api.client.post("/programs/check", json={"text": "/D00/J+5/END"})
        problem = json_of(bad)
        assert bad.status_code == 422
        assert (problem["step"], problem["field"]) == (2, "body.text.jump")
        assert [t for t in api.heard("1", mark) if t.startswith(("I", "D0"))] == []
