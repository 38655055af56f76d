"""Which line a port reaches: two spellings of one line are one, and an absent device says so."""

from __future__ import annotations

from pathlib import Path

import pytest

from gateway.transport import TransportClosed, open_transport
from gateway.transport.factory import line_identity


@pytest.mark.parametrize(
    ("one", "other"),
    [
        ("socket://moxa.local:4001", "socket://MOXA.Local.:4001"),
        ("socket://10.0.0.7:4001", "rfc2217://10.0.0.7:4001"),  # one port of the server
        ("socket://[::1]:4001", "socket://[0:0:0::1]:4001"),
        ("rfc2217://10.0.0.7:2217?ign_set_control", "rfc2217://10.0.0.7:2217"),
    ],
)
def test_two_spellings_of_one_network_line_are_one(one: str, other: str) -> None:
    assert line_identity(one) == line_identity(other)


@pytest.mark.parametrize(
    ("one", "other"),
    [
        ("socket://moxa.local:4001", "socket://moxa.local:4002"),
        ("socket://localhost:4001", "socket://127.0.0.1:4001"),  # names are not resolved
    ],
)
def test_other_lines_stay_apart(one: str, other: str) -> None:
    assert line_identity(one) != line_identity(other)


def test_a_device_is_known_by_what_its_links_point_to(tmp_path: Path) -> None:
    device = tmp_path / "ttyUSB0"
    device.touch()
    by_id = tmp_path / "by-id"
    by_id.mkdir()
    (by_id / "usb-FTDI-port0").symlink_to(device)
    assert line_identity(str(by_id / "usb-FTDI-port0")) == line_identity(str(device))
    assert line_identity(str(tmp_path / "." / "ttyUSB0")) == str(device)


def test_a_bad_url_is_refused_as_open_transport_refuses_it() -> None:
    with pytest.raises(ValueError, match="a device path must be absolute"):
        line_identity("ttyUSB0")


async def test_an_absent_device_fails_to_open_saying_it_is_not_present(tmp_path: Path) -> None:
    # The cause a loop shows while its adapter is unplugged, said once and plainly.
    missing = tmp_path / "serial" / "by-id" / "usb-adapter"
    line = open_transport(str(missing), 9600)
    with pytest.raises(TransportClosed) as failed:
        await line.open()
    assert str(failed.value) == (
        f"{missing}: cannot open: the device is not present (No such file or directory)"
    )
    assert not line.is_open
