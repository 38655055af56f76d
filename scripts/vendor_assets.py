"""Vendor the dashboard's third-party assets from the npm registry, pinned and hashed.

The dashboard and the API docs must work on a factory network with no internet, so every
asset they load is a file of this package. This script is how those files get here: for each
pinned package it runs ``npm pack <name>@<version>`` (npm checks the tarball against the
registry's ``integrity``), copies the few files the page needs out of the tarball and writes
``manifest.json`` beside them: package, version, the tarball's integrity and, per file, its
path in the package and its SHA-256. ``tests/api/test_dashboard_assets.py`` re-hashes the
vendored files against the manifest, so a file edited by hand (or half-copied) fails the suite.

Run it only to change a pin: ``python3 scripts/vendor_assets.py`` (needs ``npm`` and the
registry; nothing at build, run or test time does).
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
import tarfile
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
VENDOR = ROOT / "gateway" / "api" / "dashboard" / "static" / "vendor"
MANIFEST = VENDOR / "manifest.json"


@dataclass(frozen=True)
class Pin:
    """One npm package at one version, and which of its files to copy (path in the tarball
    under ``package/`` -> name under ``vendor/<into>/``)."""

    name: str
    version: str
    into: str
    files: dict[str, str]


PINS = (
    # Preact with its hooks and htm in one ES module: components without a build step.
    Pin(
        "htm",
        "3.1.1",
        "preact-htm",
        {"preact/standalone.module.js": "standalone.module.js", "LICENSE": "LICENSE"},
    ),
    # uPlot: a canvas time-series plot light enough for 30 axes at 20 updates/s.
    Pin(
        "uplot",
        "1.6.32",
        "uplot",
        {
            "dist/uPlot.esm.js": "uPlot.esm.js",
            "dist/uPlot.min.css": "uPlot.min.css",
            "LICENSE": "LICENSE",
        },
    ),
    # Swagger UI for /api/v1/docs.
    Pin(
        "swagger-ui-dist",
        "5.30.2",
        "swagger-ui",
        {
            "swagger-ui-bundle.js": "swagger-ui-bundle.js",
            "swagger-ui.css": "swagger-ui.css",
            "favicon-32x32.png": "favicon-32x32.png",
            "LICENSE": "LICENSE",
        },
    ),
    # ReDoc for /api/v1/redoc: one ES module with its styles (styled-components, CSSOM).
    Pin(
        "redoc",
        "3.0.1",
        "redoc",
        {"bundles/redoc.standalone.js": "redoc.standalone.js", "LICENSE": "LICENSE"},
    ),
)


def sha256(data: bytes) -> str:
    """The hex SHA-256 of ``data``."""
    return hashlib.sha256(data).hexdigest()


def pack(pin: Pin, workdir: Path) -> tuple[Path, str]:
    """``npm pack`` the pinned package into ``workdir``: the tarball and its integrity."""
    out = subprocess.run(
        ["npm", "pack", f"{pin.name}@{pin.version}", "--json", "--pack-destination", str(workdir)],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    info = json.loads(out)[0]
    if info["version"] != pin.version:
        raise SystemExit(f"{pin.name}: npm gave {info['version']}, pinned {pin.version}")
    return workdir / info["filename"], str(info["integrity"])


def vendor(pin: Pin, workdir: Path) -> dict[str, Any]:
    """Copy the pinned files of one package; its manifest entry."""
    tarball, integrity = pack(pin, workdir)
    target = VENDOR / pin.into
    target.mkdir(parents=True, exist_ok=True)
    files = []
    with tarfile.open(tarball, "r:gz") as tar:
        for source, name in pin.files.items():
            member = tar.extractfile(f"package/{source}")
            if member is None:
                raise SystemExit(f"{pin.name}@{pin.version} has no file {source}")
            data = member.read()
            (target / name).write_bytes(data)
            files.append(
                {"path": f"{pin.into}/{name}", "package_path": source, "sha256": sha256(data)}
            )
    return {
        "name": pin.name,
        "version": pin.version,
        "integrity": integrity,
        "tarball": f"https://registry.npmjs.org/{pin.name}/-/{tarball.name}",
        "files": files,
    }


def main() -> int:
    """Vendor every pin and write the manifest."""
    with tempfile.TemporaryDirectory() as tmp:
        packages = [vendor(pin, Path(tmp)) for pin in PINS]
    MANIFEST.write_text(json.dumps({"packages": packages}, indent=2) + "\n")
    for package in packages:
        print(f"{package['name']}@{package['version']}: {len(package['files'])} files")
    return 0


if __name__ == "__main__":
    sys.exit(main())
