"""The curated package API: everything exported exists, and nothing private leaks in."""

from __future__ import annotations

import gateway.protocol


def test_every_exported_name_exists() -> None:
    for name in gateway.protocol.__all__:
        assert hasattr(gateway.protocol, name), name
    assert all(not name.startswith("_") for name in gateway.protocol.__all__)


def test_a_manual_example_end_to_end() -> None:
    # §10 SUM: '$16' sent with checksum on is '$168B'; '>$100000300' + checksum decodes to 300.
    from gateway.protocol import Framing, ReplyFormat, decode_reply, encode_command, parse

    command = parse("6")
    assert encode_command("1", command.wire(), framing=Framing(checksum=True)) == b"$168B\r"
    assert command.reply_format is ReplyFormat.POSITION
    assert decode_reply(command.reply_format, "00000300") == 300
