"""Secrets masked in every log record, whoever logs it."""

from __future__ import annotations

import logging

import pytest

from gateway.api.redaction import install_log_redaction, redact


@pytest.mark.parametrize(
    ("text", "masked"),
    [
        ('"WebSocket /ws?token=VIEWtok123" [accepted]', '"WebSocket /ws?token=***" [accepted]'),
        ("GET /x?a=1&token=s3cr3t&b=2 HTTP/1.1", "GET /x?a=1&token=***&b=2 HTTP/1.1"),
        ("/x?access_token=abc#frag", "/x?access_token=***#frag"),
        ("Authorization: Bearer abc.def-ghi", "Authorization: Bearer ***"),
        ("no secret here: tokens=3 mytoken=4", "no secret here: tokens=3 mytoken=4"),
    ],
)  # fmt: skip
def test_redact_masks_token_values_only(text: str, masked: str) -> None:
    assert redact(text) == masked


def test_every_logger_is_redacted_once_installed(caplog: pytest.LogCaptureFixture) -> None:
    install_log_redaction()
    install_log_redaction()  # again: no second wrapper
    with caplog.at_level(logging.INFO):
        logging.getLogger("uvicorn.error").info(
            '%s - "WebSocket %s" [accepted]', "1.2.3.4:5", "/ws?token=t0k"
        )
        logging.getLogger("somewhere.else").warning("header was Bearer %s", "t0k2")
    assert "t0k" not in caplog.text
    assert '"WebSocket /ws?token=***" [accepted]' in caplog.text
    assert "Bearer ***" in caplog.text
