"""``rc233-gateway trace LOOP`` and ``rc233-gateway audit``: a running gateway, from a terminal.

Both talk to the API of a gateway (``--url``, default http://127.0.0.1:8233) with an admin
token (``--token`` or ``$RC233_TOKEN``), so they work from any machine that can reach it and
leave the same audit trail as any client. They are plain blocking programs (the standard
library's HTTP client: nothing beyond the runtime dependencies), polling every ``--interval``
seconds:

* ``trace LOOP`` switches the loop's line trace on (unless it already is), prints every new
  traced chunk as one line (``time  tx|rx  controller  text``) and, on Ctrl-C, switches it
  back off if it had switched it on. ``--once`` prints what is kept and ends.
* ``audit`` prints the newest entries (``--limit``) or those after ``--since``; ``--follow``
  keeps printing new ones until Ctrl-C. ``--json`` prints the entries as JSON lines.

Exit codes: 0, 2 for a refused request (the problem's title and detail are printed), 3 when
the gateway cannot be reached.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Callable
from datetime import UTC, datetime
from typing import Any

__all__ = ["add_remote_parsers", "format_audit", "format_trace"]

DEFAULT_URL = "http://127.0.0.1:8233"


class Refused(Exception):
    """The gateway answered with an error status."""


class Api:
    """A minimal client of the gateway's API (blocking; the CLI has nothing else to do)."""

    def __init__(self, url: str, token: str | None, timeout: float = 10.0) -> None:
        self.base = url.rstrip("/") + "/api/v1"
        self.token = token
        self.timeout = timeout

    def call(self, method: str, path: str, body: dict[str, Any] | None = None) -> Any:
        """The decoded JSON answer; ``Refused`` for an error status."""
        data = None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(self.base + path, data=data, method=method)
        request.add_header("Accept", "application/json")
        if data is not None or method != "GET":  # every act is declared JSON, bodyless too
            request.add_header("Content-Type", "application/json")
        if self.token:
            request.add_header("Authorization", f"Bearer {self.token}")
        try:
            with urllib.request.urlopen(request, timeout=self.timeout) as response:
                return json.loads(response.read() or b"null")
        except urllib.error.HTTPError as exc:
            try:
                problem = json.loads(exc.read())
                text = f"{exc.code} {problem.get('title', '')}: {problem.get('detail', '')}"
            except ValueError:
                text = f"{exc.code} {exc.reason}"
            raise Refused(f"{method} {path}: {text}") from None


def _clock(seconds: float | None) -> str:
    if seconds is None:
        return "--:--:--.---"
    moment = datetime.fromtimestamp(seconds, UTC)
    return moment.strftime("%H:%M:%S.") + f"{moment.microsecond // 1000:03d}"


def format_trace(line: dict[str, Any]) -> str:
    """One traced chunk as a terminal line: time, direction, controller, text, note."""
    note = f"  ({line['note']})" if line.get("note") else ""
    return (
        f"{_clock(line.get('time'))}  {line['direction']:<7} {line.get('controller') or '-':<8} "
        f"{line['text']}{note}"
    )


def format_audit(entry: dict[str, Any]) -> str:
    """One audit entry as a terminal line: seq, time, who, request, status, what was sent."""
    frames = entry.get("bytes_sent") or []
    sent = frames if isinstance(frames, str) else " ".join(frames)
    query = f"?{entry['query']}" if entry.get("query") else ""
    # an entry written ahead of its request has no status yet
    status = "ahead" if entry.get("event") == "intent" else entry.get("status")
    return (
        f"{entry['seq']:>6} {entry['time']}  {entry.get('token') or '-'}  "
        f"{entry['method']} {entry['path']}{query} -> {status}" + (f"  sent {sent}" if sent else "")
    )


def _poll(interval: float, step: Callable[[], None]) -> None:
    """Run ``step`` every ``interval`` seconds until Ctrl-C."""
    try:
        while True:
            step()
            sys.stdout.flush()
            time.sleep(interval)
    except KeyboardInterrupt:
        pass


def _trace(args: argparse.Namespace, api: Api) -> int:
    path = f"/loops/{urllib.parse.quote(args.loop)}/trace"
    query = f"?controller={urllib.parse.quote(args.controller)}" if args.controller else ""
    before = api.call("GET", path)
    switched = not before["enabled"] and not args.once
    if switched:
        api.call("PUT", path, {"enabled": True, "hex": args.hex, "controllers": []})
    seen: set[tuple[Any, ...]] = set()
    last = float("-inf")

    def step() -> None:
        nonlocal last
        for line in api.call("GET", path + query)["lines"]:  # oldest first
            moment = line.get("time") or 0.0
            key = (moment, line["direction"], line.get("controller"), line["text"])
            if moment < last or (moment == last and key in seen):
                continue  # printed already (the trace has no sequence numbers)
            if moment > last:
                last = moment
                seen.clear()
            seen.add(key)
            print(format_trace(line))

    try:
        if args.once:
            step()
        else:
            _poll(args.interval, step)
    finally:
        if switched:
            api.call("PUT", path, {"enabled": False, "hex": before["hex"], "controllers": []})
    return 0


def _audit(args: argparse.Namespace, api: Api) -> int:
    since: str | None = args.since

    def step() -> None:
        nonlocal since
        query = {"limit": str(args.limit)} | ({"since": since} if since is not None else {})
        page = api.call("GET", "/audit?" + urllib.parse.urlencode(query))
        for entry in page["entries"]:
            print(json.dumps(entry, ensure_ascii=False) if args.json else format_audit(entry))
        since = str(page["entries"][-1]["seq"] if page["entries"] else page["last_seq"])

    if args.follow:
        _poll(args.interval, step)
    else:
        step()
    return 0


def _run(handler: Callable[[argparse.Namespace, Api], int]) -> Callable[[argparse.Namespace], int]:
    def run(args: argparse.Namespace) -> int:
        api = Api(args.url, args.token or os.environ.get("RC233_TOKEN"))
        try:
            return handler(args, api)
        except Refused as exc:
            print(f"rc233-gateway {args.cmd}: refused: {exc}", file=sys.stderr)
            return 2
        except (urllib.error.URLError, OSError) as exc:
            print(f"rc233-gateway {args.cmd}: cannot reach {args.url}: {exc}", file=sys.stderr)
            return 3

    return run


def _common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--url", default=DEFAULT_URL, help=f"the gateway (default {DEFAULT_URL})")
    parser.add_argument("--token", help="an admin token (default: $RC233_TOKEN)")
    parser.add_argument(
        "--interval", type=float, default=0.5, help="seconds between polls (default 0.5)"
    )


def add_remote_parsers(subparsers: Any) -> None:
    """Add ``trace`` and ``audit`` to the subcommands."""
    trace = subparsers.add_parser("trace", help="follow a loop's line trace (admin token)")
    trace.add_argument("loop", help="the loop's name")
    trace.add_argument("--controller", help="only this controller (body, id or name)")
    trace.add_argument("--hex", action="store_true", help="bytes as hex")
    trace.add_argument("--once", action="store_true", help="print what is kept and end")
    _common(trace)
    trace.set_defaults(func=_run(_trace))
    audit = subparsers.add_parser("audit", help="print or follow the audit log (admin token)")
    audit.add_argument("--follow", "-f", action="store_true", help="keep printing new entries")
    audit.add_argument("--since", help="entries after this seq or ISO 8601 time")
    audit.add_argument("--limit", type=int, default=100, help="entries a request (default 100)")
    audit.add_argument("--json", action="store_true", help="entries as JSON lines")
    _common(audit)
    audit.set_defaults(func=_run(_audit))
