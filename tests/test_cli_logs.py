"""The log format of `serve`, the systemd notification and the terminal lines of trace/audit,
in process (the end-to-end runs are in tests/deploy and tests/api/test_cli_remote.py)."""

from __future__ import annotations

import io
import json
import logging
import socket
from pathlib import Path

import pytest

from gateway.cli.logs import JsonFormatter, configure_logging
from gateway.cli.notify import notify
from gateway.cli.remote import format_audit, format_trace


def _record(msg: str, *args: object, **extra: object) -> logging.LogRecord:
    record = logging.LogRecord("gateway.bus", logging.WARNING, __file__, 1, msg, args, None)
    record.__dict__.update(extra)
    return record


def test_a_json_line_carries_the_context_first_then_the_other_extras() -> None:
    line = json.loads(
        JsonFormatter().format(
            _record("controller %s offline", "main.3", event="controller_offline",
                    controller="main.3", loop="main", zeta=1)
        )
    )  # fmt: skip
    assert list(line) == [
        "time", "level", "logger", "message", "event", "loop", "controller", "zeta",
    ]  # fmt: skip
    assert line["message"] == "controller main.3 offline" and line["time"].endswith("Z")


def test_the_schedulers_own_lines_get_their_loop_from_the_message() -> None:
    line = json.loads(JsonFormatter().format(_record("loop %s down: %s", "main", "no answer")))
    assert (line["loop"], line["message"]) == ("main", "loop main down: no answer")
    other = json.loads(JsonFormatter().format(_record("line did not close within %.1f s", 2.0)))
    assert "loop" not in other


def test_an_exception_is_one_json_line_too() -> None:
    try:
        raise ValueError("boom")
    except ValueError:
        record = _record("failed")
        record.exc_info = __import__("sys").exc_info()
    text = JsonFormatter().format(record)
    assert "\n" not in text
    assert "ValueError: boom" in json.loads(text)["exception"]


def test_configure_logging_writes_json_to_stderr(monkeypatch: pytest.MonkeyPatch) -> None:
    stream = io.StringIO()
    monkeypatch.setattr("sys.stderr", stream)
    root = logging.getLogger()
    saved = (root.handlers[:], root.level)
    try:
        configure_logging("json")
        logging.getLogger("gateway.state").info("loop %s up", "main", extra={"event": "loop_up"})
        logging.getLogger("gateway.state").debug("not at INFO")
    finally:
        root.handlers[:], root.level = saved[0], saved[1]
    (line,) = stream.getvalue().splitlines()
    assert json.loads(line)["event"] == "loop_up"


def test_notify_sends_one_datagram_to_the_socket_systemd_gave(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("NOTIFY_SOCKET", raising=False)
    assert notify("READY=1") is False  # not under systemd: nothing to do
    for name in (str(tmp_path / "notify"), f"@rc233-test-{id(tmp_path)}"):
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as receiver:
            receiver.bind(name if not name.startswith("@") else "\0" + name[1:])
            monkeypatch.setenv("NOTIFY_SOCKET", name)
            assert notify("READY=1") is True
            assert receiver.recv(100) == b"READY=1"


def test_terminal_lines_of_trace_and_audit() -> None:
    traced = {"time": 0.25, "direction": "tx", "controller": "main.1", "text": "$1\\r",
              "note": ""}  # fmt: skip
    assert format_trace(traced) == "00:00:00.250  tx      main.1   $1\\r"
    noted = traced | {"direction": "note", "controller": None, "text": "", "note": "timeout"}
    assert format_trace(noted) == "00:00:00.250  note    -" + " " * 10 + "(timeout)"
    entry = {"seq": 7, "time": "2026-11-25T18:00:00Z", "token": "mes", "method": "POST",
             "path": "/api/v1/axes/x/move", "query": "wait=true", "status": 200,
             "bytes_sent": ["$1F1", "$1A1250"]}  # fmt: skip
    assert format_audit(entry) == (
        "     7 2026-11-25T18:00:00Z  mes  POST /api/v1/axes/x/move?wait=true -> 200"
        "  sent $1F1 $1A1250"
    )
