"""Every file, directory and module that README.md and docs/*.md name exists.

Three kinds of names are checked: a path from the repository's root (``gateway/api/app.py``,
``tests/api/test_audit.py``, ``deploy/prometheus``), a path inside the package
(``bus/scheduler.py``, ``api/routes/deps.py``) and a dotted name (``gateway.api.app``,
``gateway.api.ws.endpoint.uvicorn_ws_options``: a module, then the names defined in it). A
dotted name that is one of the gateway's logger names (``gateway.access``) is a logger, not a
module. Modules move (api/ into subpackages, bus/ and service/ files renamed): a page that
still names the old place fails here, naming the page, the line and the name.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "gateway"
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

#: top-level directories of the repository a page may name
_TOP = "gateway|tests|tools|bench|deploy|examples|scripts|docs|openapi"
#: subpackages of gateway/ a page may name without the ``gateway/`` in front
_SUB = "api|bus|cli|engine|mqtt|opcua|protocol|service|sim|transport"
# A name starts after a space, a quote, a bracket or a backtick; not inside a longer path
# (``/etc/rc233-gateway/cell.toml`` names no file of the repository).
_ROOTED = re.compile(rf"(?<![\w./~-])((?:{_TOP})/[\w./-]*[\w/])")
_INSIDE = re.compile(rf"(?<![\w./~-])((?:{_SUB})/[\w/]*\w\.py)\b")
_DOTTED = re.compile(r"(?<![\w./-])(gateway(?:\.\w+)+)")
#: made by a tool, not kept in git (`npm ci` in tools/asyncapi)
_GENERATED = ("tools/asyncapi/node_modules",)
_LOGGER = re.compile(r"getLogger\(\s*\"([\w.]+)\"")


def _loggers() -> set[str]:
    names: set[str] = set()
    for source in PACKAGE.rglob("*.py"):
        names.update(_LOGGER.findall(source.read_text("utf-8")))
    return names


def _module_exists(dotted: str) -> bool:
    """``gateway.a.b`` is a module or package of the source tree, or names defined in one."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        base = ROOT.joinpath(*parts[:cut])
        if base.with_suffix(".py").is_file() or (base / "__init__.py").is_file():
            break
    else:
        return False
    if cut == len(parts):
        return True
    value: object = importlib.import_module(".".join(parts[:cut]))
    for name in parts[cut:]:
        if not hasattr(value, name):
            return False
        value = getattr(value, name)
    return True


def _missing() -> list[str]:
    loggers = _loggers()
    missing: list[str] = []
    for page in PAGES:
        for number, line in enumerate(page.read_text("utf-8").splitlines(), 1):
            where = f"{page.relative_to(ROOT)}:{number}"
            for name in _ROOTED.findall(line):
                name = name.rstrip(".")
                if name.startswith(_GENERATED) or (ROOT / name).exists():
                    continue
                missing.append(f"{where}: {name}")
            for name in _INSIDE.findall(line):
                if not (PACKAGE / name).exists():
                    missing.append(f"{where}: {name} (in gateway/)")
            for name in _DOTTED.findall(line):
                if name not in loggers and not _module_exists(name):
                    missing.append(f"{where}: {name}")
    return missing


def test_the_pages_name_only_paths_and_modules_that_exist() -> None:
    missing = _missing()
    assert not missing, "names of files or modules that do not exist:\n" + "\n".join(missing)


def test_the_check_finds_a_moved_module() -> None:
    # What the check would say of names as they were before api/ had subpackages.
    assert not _module_exists("gateway.api.deps")
    assert not (PACKAGE / "api/deps.py").exists()
    assert _module_exists("gateway.api.routes.deps")
    assert _module_exists("gateway.api.app.API_PREFIX")
    assert _ROOTED.findall("see `gateway/api/deps.py`.") == ["gateway/api/deps.py"]
    assert _INSIDE.findall("in api/routes/deps.py,") == ["api/routes/deps.py"]
    assert _ROOTED.findall("/etc/rc233-gateway/cell.toml") == []
