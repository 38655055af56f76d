"""The running gateway takes its transports from whoever owns the process: it opens none."""

from __future__ import annotations

import pytest

from gateway.service.config import parse_config
from gateway.service.runtime import Runtime

CELL = {"loops": [{"name": "main", "port": "socket://127.0.0.1:5233", "controllers": [
    {"body": "1"}]}]}  # fmt: skip


def test_a_configured_port_is_not_opened_by_the_runtime_itself() -> None:
    # A port the runtime could open is still refused without a transport handed over: the
    # command line (or a test) opens the lines, never the service layer.
    with pytest.raises(ValueError, match=r"no transport for the loops \['main'\]"):
        Runtime(parse_config(CELL), transports={})
