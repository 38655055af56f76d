"""``rc233-gateway check-config FILE``: every problem of a configuration, before anything starts.

The schema (``gateway.service.config``) says what a value may be; this module checks what the
site must hold for the values to work, on this machine, as the user running the check:

* ``audit_log``: its directory exists and this user may write the file (the gateway appends
  every mutating request to it; a file it cannot write would lose the record);
* ``loops[i].port``: a serial port (a terminal, not merely a character device) or a
  well-formed ``socket://HOST:PORT`` / ``rfc2217://HOST:PORT`` (a network line is not dialled:
  whether it answers is what ``/readyz`` reports), each line used by one loop only
  (``gateway.cli.port_checks``). A device that does not exist yet is a warning: that loop
  starts down and comes up when it appears (``--strict``: a problem);
* ``opcua``: the certificate, key and trusted-clients folder it names exist, and someone can
  log in (a token, or ``anonymous = true``);
* ``security.tokens``: at least one, unless the API is to run open (``--no-auth``); the
  example file's placeholders are not digests, so they fail the schema.

Both kinds of problem are listed together, each named by its key, so one run shows them all
(the first 50, then how many more). The file is read with bounds first (size, encoding,
nesting, key length: ``gateway.service.config_bounds``), so no file makes the check run out of
memory or time. ``serve`` runs the same checks and refuses to start while any is left; it
starts with warnings and logs them.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from gateway.cli.port_checks import port_findings
from gateway.service.config import ConfigError, GatewayConfig, schema_problems
from gateway.service.config_bounds import UnreadableConfig, listed, read_toml

__all__ = [
    "NO_TOKENS",
    "ConfigReport",
    "add_check_config_parser",
    "check_file",
    "check_report",
    "opcua_problems",
    "site_problems",
]

#: the problem of a configuration without tokens, when the API is not to run open
NO_TOKENS = (
    "security.tokens: no API token is configured; add one (`rc233-gateway token`), or run "
    "the API open with `serve --no-auth` (loopback only)"
)


def _audit_problem(value: Any) -> str | None:
    if value is None:
        return None
    if "\0" in str(value):  # the OS refuses such a path: said here, not as a traceback
        return f"audit_log: {str(value)!r} holds a NUL character"
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


@dataclass
class ConfigReport:
    """What ``check-config`` found in a file: its configuration (None when it breaks the
    schema), the problems (nothing starts while one is left) and the warnings."""

    config: GatewayConfig | None
    problems: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def _site(data: Mapping[str, Any], *, ports: bool) -> ConfigReport:
    report = ConfigReport(None)
    audit = os.environ.get("RC233_AUDIT_LOG", data.get("audit_log"))
    if (problem := _audit_problem(audit)) is not None:
        report.problems.append(problem)
    if ports:
        found = port_findings(data.get("loops"))
        report.problems += found.problems
        report.warnings += found.warnings
    return report


def site_problems(data: Mapping[str, Any], *, ports: bool = True) -> list[str]:
    """What the site must hold for ``data`` (the file's values, checked or not) to work;
    ``ports=False`` leaves the loops' ports out (``serve --simulate`` replaces them)."""
    return _site(data, ports=ports).problems


def check_report(
    path: Path, *, no_auth: bool = False, ports: bool = True, strict: bool = False
) -> ConfigReport:
    """Everything ``check-config`` finds in ``path``; ``strict``: warnings are problems."""
    try:
        data = read_toml(path)  # bounded: size, encoding, nesting, key length
    except OSError as exc:
        return ConfigReport(None, [f"(file): cannot read {path} ({exc.strerror})"])
    except UnreadableConfig as exc:
        return ConfigReport(None, [f"(file): {exc}"])
    config: GatewayConfig | None = None
    schema: list[str] = []
    try:
        config = GatewayConfig(**data)
    except ValidationError as exc:
        schema = schema_problems(exc)
    report = _site(data, ports=ports)
    report.config = config
    report.problems[:0] = schema
    if config is not None and not no_auth and not config.security.tokens:
        report.problems.append(NO_TOKENS)
    if config is not None and config.opcua is not None:
        report.problems += opcua_problems(config)
    if strict:
        report.problems += report.warnings
        report.warnings = []
    return report


def opcua_problems(config: GatewayConfig) -> list[str]:
    """What the ``[opcua]`` section needs of the site: its files there, a way to log in."""
    opcua = config.opcua
    if opcua is None:
        return []
    problems = []
    for key, path in (("certificate", opcua.certificate), ("private_key", opcua.private_key)):
        if path is not None and not path.is_file():
            problems.append(f"opcua.{key}: {path} is not a file")
    if opcua.trusted_clients is not None and not opcua.trusted_clients.is_dir():
        problems.append(f"opcua.trusted_clients: {opcua.trusted_clients} is not a directory")
    if not config.security.tokens and not opcua.anonymous:
        problems.append(
            "opcua: no token is configured and anonymous = false, so nobody could log in; "
            "add a token (`rc233-gateway token`) or set anonymous = true (viewers)"
        )
    return problems


def check_file(
    path: Path, *, no_auth: bool = False, ports: bool = True
) -> tuple[GatewayConfig | None, list[str]]:
    """The configuration of ``path`` (None when it breaks the schema) and every problem."""
    report = check_report(path, no_auth=no_auth, ports=ports)
    return report.config, report.problems


def problems_error(path: Path, problems: Sequence[str]) -> ConfigError:
    """One error listing ``problems`` of ``path``, as ``serve`` reports them."""
    lines = [f"{path}: {len(problems)} problem(s)", *problems_lines(problems)]
    return ConfigError("\n".join(lines))


def problems_lines(problems: Sequence[str]) -> list[str]:
    """``problems`` indented, one a line: the first ``MAX_LISTED``, then how many more."""
    return [f"  {problem}" for problem in listed(problems)]


def _check(args: argparse.Namespace) -> int:
    report = check_report(args.file, no_auth=args.no_auth, strict=args.strict)
    config, problems = report.config, report.problems
    if problems:
        print(f"{args.file}: {len(problems)} problem(s)")
        print("\n".join(problems_lines(problems)))
    if report.warnings:
        print(f"{args.file}: {len(report.warnings)} warning(s)")
        print("\n".join(problems_lines(report.warnings)))
    if problems:
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
    check.add_argument(
        "--strict",
        action="store_true",
        help="warnings (a serial device not present now) are problems too (exit 1)",
    )
    check.set_defaults(func=_check)
