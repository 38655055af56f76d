"""``rc233-gateway check-config FILE``: every problem of a configuration, before anything starts.

The schema (``gateway.service.config``) says what a value may be; this module checks what the
site must hold for the values to work, on this machine, as the user running the check:

* ``audit_log``: its directory exists and this user may write the file (the gateway appends
  every mutating request to it; a file it cannot write would lose the record);
* ``loops[i].port``: a device path that exists, is a character device and may be opened for
  reading and writing, or a well-formed ``socket://HOST:PORT`` / ``rfc2217://HOST:PORT`` (a
  network line is not dialled: whether it answers is what ``/readyz`` reports);
* ``security.tokens``: at least one, unless the API is to run open (``--no-auth``); the
  example file's placeholders are not digests, so they fail the schema.

Both kinds of problem are listed together, each named by its key, so one run shows them all.
``serve`` runs the same checks and refuses to start while any is left.
"""

from __future__ import annotations

import argparse
import os
import stat
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from gateway.service.config import ConfigError, GatewayConfig, parse_config
from gateway.transport import LineKind

__all__ = ["NO_TOKENS", "add_check_config_parser", "check_file", "site_problems"]

#: the problem of a configuration without tokens, when the API is not to run open
NO_TOKENS = (
    "security.tokens: no API token is configured; add one (`rc233-gateway token`), or run "
    "the API open with `serve --no-auth` (loopback only)"
)


def _audit_problem(value: Any) -> str | None:
    if value is None:
        return None
    path = Path(str(value))
    if path.is_dir():
        return f"audit_log: {path} is a directory, not a file"
    if not path.parent.is_dir():
        return f"audit_log: the directory {path.parent} does not exist"
    if path.exists():
        if not os.access(path, os.W_OK):
            return f"audit_log: {path} is not writable by this user"
    elif not os.access(path.parent, os.W_OK | os.X_OK):
        return f"audit_log: this user may not create files in {path.parent}"
    return None


def _port_problem(where: str, value: Any) -> str | None:
    url = str(value)
    try:
        kind = LineKind.of(url)
    except ValueError as exc:
        return f"{where}: {exc}"
    if kind is not LineKind.DEVICE:
        return None
    try:
        mode = os.stat(url).st_mode
    except OSError as exc:
        return f"{where}: {url}: {exc.strerror}"
    if not stat.S_ISCHR(mode):
        return f"{where}: {url} is not a serial device (a character device)"
    if not os.access(url, os.R_OK | os.W_OK):
        return f"{where}: {url} cannot be opened for reading and writing by this user"
    return None


def site_problems(data: Mapping[str, Any], *, ports: bool = True) -> list[str]:
    """What the site must hold for ``data`` (the file's values, checked or not) to work;
    ``ports=False`` leaves the loops' ports out (``serve --simulate`` replaces them)."""
    problems: list[str] = []
    audit = os.environ.get("RC233_AUDIT_LOG", data.get("audit_log"))
    if (problem := _audit_problem(audit)) is not None:
        problems.append(problem)
    loops = data.get("loops")
    if ports and isinstance(loops, Sequence):
        for i, loop in enumerate(loops):
            problem = (
                _port_problem(f"loops[{i}].port", loop["port"])
                if (isinstance(loop, Mapping) and "port" in loop)
                else None
            )
            if problem is not None:
                problems.append(problem)
    return problems


def check_file(
    path: Path, *, no_auth: bool = False, ports: bool = True
) -> tuple[GatewayConfig | None, list[str]]:
    """The configuration of ``path`` (None when it breaks the schema) and every problem."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        return None, [f"(file): cannot read {path} ({exc.strerror})"]
    except tomllib.TOMLDecodeError as exc:
        return None, [f"(file): not valid TOML ({exc})"]
    problems: list[str] = []
    config: GatewayConfig | None = None
    try:
        config = parse_config(data, str(path))
    except ConfigError as exc:
        problems += [line.strip() for line in str(exc).splitlines()[1:]]
    problems += site_problems(data, ports=ports)
    if config is not None and not no_auth and not config.security.tokens:
        problems.append(NO_TOKENS)
    return config, problems


def problems_error(path: Path, problems: Sequence[str]) -> ConfigError:
    """One error listing ``problems`` of ``path``, as ``serve`` reports them."""
    lines = [f"{path}: {len(problems)} problem(s)", *problems_lines(problems)]
    return ConfigError("\n".join(lines))


def problems_lines(problems: Sequence[str]) -> list[str]:
    """``problems`` indented, one a line."""
    return [f"  {problem}" for problem in problems]


def _check(args: argparse.Namespace) -> int:
    config, problems = check_file(args.file, no_auth=args.no_auth)
    if problems:
        print(f"{args.file}: {len(problems)} problem(s)")
        print("\n".join(problems_lines(problems)))
        return 1
    assert config is not None
    controllers = sum(len(loop.controllers) for loop in config.loops)
    print(
        f"{args.file}: ok ({len(config.loops)} loop(s), {controllers} controller(s), "
        f"{len(config.security.tokens)} token(s))"
    )
    return 0


def add_check_config_parser(subparsers: Any) -> None:
    """Add ``check-config`` to the subcommands."""
    check = subparsers.add_parser(
        "check-config",
        help="check a configuration file without starting anything (exit 1: problems)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    check.add_argument("file", type=Path, metavar="FILE", help="the cell's TOML file")
    check.add_argument(
        "--no-auth", action="store_true", help="the API will run open: no token is needed"
    )
    check.set_defaults(func=_check)
