"""The ``rc233-gateway`` command line.

``audit verify FILE`` checks audit files offline (``gateway.cli.audit_verify``).

``trace``, ``audit``, ``parse``, ``catalog`` and ``--version`` are what people type at a terminal
on site (the first two against a running gateway): they start without importing the API, the
service and the simulator (about 1.5 s of CPU on the gateway computer), which the other
subcommands import when they run.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from typing import Any

from gateway import __version__
from gateway.cli.remote import add_remote_parsers

__all__ = ["main"]


#: Subcommands served by the light parser (``_light_parser``): nothing but the protocol layer
#: (``parse``, ``catalog``) or the HTTP client (``trace``, ``audit``) behind them.
LIGHT_COMMANDS = ("trace", "audit", "parse", "catalog")


def _catalog(args: argparse.Namespace) -> int:
    from gateway.protocol.describe import catalog_json, catalog_table

    if args.json:
        print(json.dumps(catalog_json(), indent=2, ensure_ascii=False))
    else:
        print(catalog_table())
    return 0


def _parse(args: argparse.Namespace) -> int:
    from gateway.errors import InvalidInputError
    from gateway.protocol.command_text import Context, parse
    from gateway.protocol.params import PositionFormat

    context = Context.PROGRAM if args.program else Context.HOST
    positions = PositionFormat(args.positions) if args.positions else None
    try:
        command = parse(args.text, context=context, positions=positions)
    except InvalidInputError as exc:
        print(f"refused: {exc}\n  field: {exc.field}\n  rule:  {exc.rule}", file=sys.stderr)
        return 2
    print(
        json.dumps(
            {
                "command": command.key,
                "params": command.params(),
                "wire": command.wire(),
                "title": command.spec.title,
                "reply": command.reply_format.value,
                "idempotent": command.form.idempotent,
            },
            ensure_ascii=False,
        )
    )
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every subcommand."""
    from gateway.cli.check_config import add_check_config_parser
    from gateway.cli.documents import add_document_parsers
    from gateway.cli.opcua_cert import add_opcua_cert_parser
    from gateway.cli.serve import add_serve_parser
    from gateway.sim.cli import add_sim_parser

    parser, sub = _root()
    _add_protocol_parsers(sub)
    add_sim_parser(sub)
    add_serve_parser(sub)
    add_check_config_parser(sub)
    add_document_parsers(sub)
    add_opcua_cert_parser(sub)
    add_remote_parsers(sub)
    return parser


def _add_protocol_parsers(sub: Any) -> None:
    """``catalog`` and ``parse``: the protocol layer only."""
    from gateway.protocol.params import PositionFormat

    cat = sub.add_parser("catalog", help="print every command of the manual")
    cat.add_argument("--json", action="store_true", help="one JSON object per mnemonic")
    cat.set_defaults(func=_catalog)
    prs = sub.add_parser("parse", help="parse command text the way the gateway does")
    prs.add_argument("text", help="text between body number and CR, e.g. OH4000")
    prs.add_argument("--program", action="store_true", help="as a user-program statement")
    prs.add_argument("--positions", choices=[f.value for f in PositionFormat])
    prs.set_defaults(func=_parse)


def _root() -> tuple[argparse.ArgumentParser, Any]:
    parser = argparse.ArgumentParser(prog="rc233-gateway", description=__doc__)
    parser.add_argument("--version", action="version", version=f"rc233-gateway {__version__}")
    return parser, parser.add_subparsers(dest="cmd", required=True)


def _light_parser(command: str) -> argparse.ArgumentParser:
    parser, sub = _root()
    if command in ("parse", "catalog"):
        _add_protocol_parsers(sub)
    else:
        add_remote_parsers(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the console script."""
    words = list(sys.argv[1:] if argv is None else argv)
    if words[:2] == ["audit", "verify"]:  # offline, on files: not the remote ``audit``
        from gateway.cli.audit_verify import main as verify_main

        return verify_main(words[2:])
    if words[:1] == ["serve"]:  # the debug switch RC233_TRACEMALLOC, before serve imports
        from gateway.heap_trace import install_from_env

        install_from_env()
    light = bool(words) and (words[0] in LIGHT_COMMANDS or words[0] == "--version")
    args = (_light_parser(words[0]) if light else build_parser()).parse_args(words)
    code: int = args.func(args)
    return code


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
