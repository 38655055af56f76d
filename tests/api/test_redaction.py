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
        # Names as a server decodes them: the same parameter, the same mask.
        ("POST /x?tok%65n=s3cr3t HTTP/1.1", "POST /x?tok%65n=*** HTTP/1.1"),
        ("/ws?a=1&%74oken=s3cr3t", "/ws?a=1&%74oken=***"),
        ("/ws?%54%4F%4B%45%4E=s3cr3t", "/ws?%54%4F%4B%45%4E=***"),
        ("/x?access%5ftoken=abc&API_KEY=def", "/x?access%5ftoken=***&API_KEY=***"),
        ("/x?auth=Bearer%20abc.def", "/x?auth=Bearer%20***"),
        ("/x?tok%2565n=kept", "/x?tok%2565n=kept"),  # decoded once: tok%65n, no credential
    ],
)  # fmt: skip
def test_redact_masks_token_values_only(text: str, masked: str) -> None:
    assert redact(text) == masked


def test_every_logger_is_redacted_once_installed(caplog: pytest.LogCaptureFixture) -> None:
    install_log_redaction()
    install_log_redaction()  # again: no second wrapper
    # uvicorn's logger as a server configures it (an earlier test may have run uvicorn: its
    # loggers then do not propagate to the root), heard directly
    uvicorn_log = logging.getLogger("uvicorn.error")
    uvicorn_log.addHandler(caplog.handler)
    try:
        with caplog.at_level(logging.INFO), caplog.at_level(logging.INFO, "uvicorn.error"):
            uvicorn_log.info('%s - "WebSocket %s" [accepted]', "1.2.3.4:5", "/ws?token=t0k")
            logging.getLogger("somewhere.else").warning("header was Bearer %s", "t0k2")
    finally:
        uvicorn_log.removeHandler(caplog.handler)
    assert "t0k" not in caplog.text
    assert '"WebSocket /ws" [accepted]' in caplog.text  # uvicorn's line keeps no query
    assert "Bearer ***" in caplog.text


def test_a_record_made_without_a_name_is_made_all_the_same() -> None:
    install_log_redaction()
    record = logging.makeLogRecord({})  # what logging.config and formatters do
    assert record.getMessage() == ""
