"""From configuration to a line: what ``open_transport`` accepts, and the reconnect pacing."""

from __future__ import annotations

import random

import pytest

from gateway.transport import (
    BAUD_RATES,
    Backoff,
    LineKind,
    PipeTransport,
    SerialLine,
    Transport,
    TransportClosed,
    open_transport,
)


@pytest.mark.parametrize(
    ("url", "kind"),
    [
        ("/dev/ttyUSB0", LineKind.DEVICE),
        ("/dev/serial/by-id/usb-FTDI_FT232R-if00-port0", LineKind.DEVICE),
        ("socket://192.168.0.50:4001", LineKind.SOCKET),  # a Moxa NPort's first port
        ("socket://ser2net.local:3001", LineKind.SOCKET),
        ("rfc2217://[::1]:2217", LineKind.RFC2217),
        ("rfc2217://10.0.0.7:2217?ign_set_control", LineKind.RFC2217),
    ],
)
def test_the_three_kinds_of_line(url: str, kind: LineKind) -> None:
    line = open_transport(url, 9600)
    assert isinstance(line, SerialLine) and isinstance(line, Transport)
    assert (line.kind, line.url, line.baud, line.is_open) == (kind, url, 9600, False)


@pytest.mark.parametrize(
    ("url", "says"),
    [
        ("ftp://host:21", "unknown scheme 'ftp://'"),
        ("loop://", "unknown scheme 'loop://'"),  # pyserial's test URL is no line to a loop
        ("pipe://sim", "unknown scheme 'pipe://'"),  # in-process lines are made in code
        ("ttyUSB0", "a device path must be absolute"),
        ("", "a device path must be absolute"),
        ("socket://host", "expected socket://HOST:PORT"),
        ("socket://:4001", "expected socket://HOST:PORT"),
        ("socket://host:0", "expected socket://HOST:PORT"),
        ("socket://host:70000", "expected socket://HOST:PORT"),
        ("rfc2217://host:2217/extra", "expected rfc2217://HOST:PORT"),
        ("socket://host:4001?logging=debug", "socket:// takes none"),
        ("rfc2217://host:2217?speed=fast", "unknown option(s) ['speed']"),
        ("/dev/ttyS0\x00", "control characters are not allowed"),  # the OS would raise
        ("socket://host:4001\n", "control characters are not allowed"),
    ],
)
def test_a_bad_url_is_refused_naming_the_field(url: str, says: str) -> None:
    with pytest.raises(ValueError) as refused:
        open_transport(url, 9600)
    message = str(refused.value)
    assert message.startswith(f"url {url!r}")
    assert says in message
    if "device path" in says or "scheme" in says:  # and it says what would do
        assert "/dev/ttyUSB0" in message and "socket://" in message and "rfc2217://" in message


@pytest.mark.parametrize("baud", [9600, 1200, 300])
def test_the_rc233_rates_are_accepted(baud: int) -> None:
    assert open_transport("/dev/ttyS0", baud).baud == baud  # §2 仕様, §10 ES 0/1/2


@pytest.mark.parametrize("baud", [19200, 2400, 0, -9600, True, "9600", 9600.0])
def test_other_rates_are_refused_naming_the_field(baud: object) -> None:
    with pytest.raises(ValueError, match=r"^baud .*9600, 1200, 300 bps"):
        open_transport("/dev/ttyS0", baud)  # type: ignore[arg-type]
    assert BAUD_RATES == (9600, 1200, 300)


async def test_a_line_that_was_never_opened() -> None:
    line = open_transport("socket://127.0.0.1:9", 9600)
    assert not line.is_open
    assert line.discard_input() == b""
    with pytest.raises(TransportClosed, match=r"socket://127.0.0.1:9: not open"):
        line.write(b"$1\r")
    with pytest.raises(TransportClosed, match="not open"):
        await line.read()
    await line.close()  # nothing to close: nothing happens


async def test_a_peer_factory_that_fails_is_a_clear_open_error() -> None:
    def broken() -> object:
        raise RuntimeError("the line already has a host")

    line = PipeTransport(broken, url="pipe://test")  # type: ignore[arg-type]
    with pytest.raises(TransportClosed, match="pipe://test: cannot open: the line already"):
        await line.open()


def test_backoff_doubles_up_to_the_maximum_then_resets() -> None:
    backoff = Backoff(first=0.5, maximum=8.0, factor=2.0, jitter=0.0)
    assert [backoff.next_delay() for _ in range(7)] == [0.5, 1.0, 2.0, 4.0, 8.0, 8.0, 8.0]
    assert backoff.attempts == 7
    backoff.reset()
    assert backoff.next_delay() == 0.5


def test_backoff_jitter_spreads_within_its_fraction() -> None:
    backoff = Backoff(first=1.0, maximum=1.0, jitter=0.2, rng=random.Random(4))
    delays = [backoff.next_delay() for _ in range(200)]
    assert all(0.8 <= d <= 1.0 for d in delays)  # never above the maximum
    assert min(delays) < 0.85 and len(set(delays)) > 100  # spread, not one value
    many = Backoff(first=1.0, maximum=60.0, jitter=0.2, rng=random.Random(5))
    first = many.next_delay()
    assert 0.8 <= first <= 1.2


def test_backoff_survives_thousands_of_attempts() -> None:
    backoff = Backoff(first=0.5, maximum=30.0, jitter=0.0)
    for _ in range(5000):
        delay = backoff.next_delay()
    assert delay == 30.0


@pytest.mark.parametrize(
    "kwargs",
    [{"first": 0}, {"first": 5, "maximum": 1}, {"factor": 0.5}, {"jitter": 1.0}, {"jitter": -0.1}],
)
def test_backoff_refuses_settings_that_make_no_sense(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError, match="backoff"):
        Backoff(**kwargs)  # type: ignore[arg-type]
