"""The browser dashboard and the API docs, served from files of this package.

``install_dashboard(app, api_prefix)`` serves:

* ``/``: the dashboard (``static/index.html``), a client of the public REST/WebSocket API
  only: it holds no private route and no server-side state;
* ``/static/...``: its scripts and styles and the vendored libraries (``static/vendor``,
  written by ``scripts/vendor_assets.py`` with versions and SHA-256 in ``manifest.json``);
* ``{api_prefix}/docs``: Swagger UI from the vendored files, so the docs work with no internet;
* ``{api_prefix}/redoc``: ReDoc from the vendored files (its policy: ``REDOC_POLICY``).

Every file goes out with a content security policy that allows the gateway's own origin and
nothing else (no inline script, no CDN, no other host for fetch or WebSocket), and with cache
headers: the pinned vendored libraries may be cached for a day, the dashboard's own files are
revalidated each time (ETag), so an upgraded gateway is never shown with yesterday's page.
"""

from __future__ import annotations

from pathlib import Path

from fastapi import FastAPI
from starlette.requests import Request
from starlette.responses import FileResponse, RedirectResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles
from starlette.types import Scope

__all__ = [
    "CONTENT_SECURITY_POLICY",
    "EMPTY_TEXT_HASH",
    "REDOC_POLICY",
    "STATIC_DIR",
    "install_dashboard",
]

STATIC_DIR = Path(__file__).parent / "static"

#: Only the gateway's own origin: scripts, styles, images, fonts, fetch and WebSocket ('self'
#: covers ws:/wss: to the same host in CSP 3). ``data:`` images are Swagger UI's inline icons.
CONTENT_SECURITY_POLICY = (
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
    "font-src 'self'; connect-src 'self'; object-src 'none'; base-uri 'none'; "
    "form-action 'self'; frame-ancestors 'none'"
)

#: ReDoc's page: the same policy with two additions. Its styles come from styled-components,
#: which creates an empty ``<style>`` element and fills it through the CSSOM (``insertRule``,
#: which a policy does not govern): creating the empty element needs the hash of the empty
#: text, which admits no inline style text at all. Its icon font is a ``data:`` URL. Still no
#: inline script and no ``unsafe-eval`` (its search probes ``Function`` for a worker, is
#: refused and searches in the page; its "API docs by" logo from a CDN is refused).
EMPTY_TEXT_HASH = "'sha256-47DEQpj8HBSa+/TImW+5JCeuQeRkm5NMpJWZG3hSuFU='"
REDOC_POLICY = CONTENT_SECURITY_POLICY.replace(
    "style-src 'self'", f"style-src 'self' {EMPTY_TEXT_HASH}"
).replace("font-src 'self'", "font-src 'self' data:")

#: Sent with every dashboard file (the API's own security headers say the same).
SECURITY_HEADERS = {
    "Content-Security-Policy": CONTENT_SECURITY_POLICY,
    "X-Content-Type-Options": "nosniff",
    "X-Frame-Options": "DENY",
    "Referrer-Policy": "no-referrer",
    "Cross-Origin-Opener-Policy": "same-origin",
    "Cross-Origin-Resource-Policy": "same-origin",
}

#: The dashboard's own files: revalidated every time (cheap: ETag / If-None-Match -> 304).
OWN_FILES_CACHE = "no-cache"
#: Pinned third-party files: their content changes only with a new pin.
VENDOR_CACHE = "public, max-age=86400"


def _secure(response: Response, cache: str) -> Response:
    response.headers.update(SECURITY_HEADERS)
    response.headers["Cache-Control"] = cache
    return response


class _Files(StaticFiles):
    """Static files with the dashboard's security and cache headers."""

    async def get_response(self, path: str, scope: Scope) -> Response:
        response = await super().get_response(path, scope)
        vendored = path.replace("\\", "/").startswith("vendor/")
        return _secure(response, VENDOR_CACHE if vendored else OWN_FILES_CACHE)


def install_dashboard(app: FastAPI, api_prefix: str) -> None:
    """Serve the dashboard at ``/``, its files at ``/static``, the docs at ``{api_prefix}/docs``
    and ``{api_prefix}/redoc``."""

    async def index(request: Request) -> Response:
        return _secure(FileResponse(STATIC_DIR / "index.html"), OWN_FILES_CACHE)

    async def docs(request: Request) -> Response:
        return _secure(FileResponse(STATIC_DIR / "docs.html"), OWN_FILES_CACHE)

    async def redoc(request: Request) -> Response:
        response = _secure(FileResponse(STATIC_DIR / "redoc.html"), OWN_FILES_CACHE)
        response.headers["Content-Security-Policy"] = REDOC_POLICY
        return response

    async def to_docs(request: Request) -> Response:
        # The API's root, which older start-up logs printed: a browser there wants the docs.
        return RedirectResponse(f"{api_prefix}/docs", status_code=307)

    app.router.routes.extend(
        [
            Route("/", index, methods=["GET", "HEAD"], name="dashboard"),
            Route(f"{api_prefix}/docs", docs, methods=["GET", "HEAD"], name="api_docs"),
            Route(f"{api_prefix}/redoc", redoc, methods=["GET", "HEAD"], name="api_redoc"),
            Route(api_prefix, to_docs, methods=["GET", "HEAD"], name="api_root"),
            Mount("/static", _Files(directory=STATIC_DIR), name="static"),
        ]
    )
