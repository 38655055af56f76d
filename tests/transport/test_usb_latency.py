"""A device path's adapter: the low-latency flag and the latency timer, read at every open.

The simulator behind a pseudo-terminal is the device (``PtyLine``); the adapter's sysfs is a
directory of the test's own (``sysfs_root``), holding ``latency_timer`` for the tty the
configured path resolves to, as the kernel holds it for an FTDI adapter.
"""

from __future__ import annotations

import logging
import os
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from gateway.sim.loop import SimLoop
from gateway.sim.serve import PtyLine
from gateway.transport import SerialLine
from gateway.transport.usb_latency import read_latency_timer, tty_name
from tests.transport import CHECK, CHECK_REPLY, exchange

TRANSPORT_LOG = "gateway.transport"


@pytest.fixture
async def pty(sim: SimLoop) -> AsyncIterator[PtyLine]:
    line = PtyLine(sim)
    line.start()
    yield line
    line.close()


def fake_sysfs(root: Path, tty: str, latency_timer: str) -> Path:
    """A sysfs tree where usb-serial device ``tty`` has the latency timer given (ms)."""
    device = root / "bus" / "usb-serial" / "devices" / tty
    device.mkdir(parents=True, exist_ok=True)
    (device / "latency_timer").write_text(latency_timer)
    return root


def records(caplog: pytest.LogCaptureFixture, level: int) -> list[str]:
    return [
        r.getMessage() for r in caplog.records if r.name == TRANSPORT_LOG and r.levelno == level
    ]


def test_the_timer_is_found_through_the_links_of_the_configured_path(tmp_path: Path) -> None:
    # /dev/serial/by-id/... is a link to ../../ttyUSB3: the kernel's name is what sysfs uses.
    dev = tmp_path / "dev"
    (dev / "serial" / "by-id").mkdir(parents=True)
    (dev / "ttyUSB3").touch()
    by_id = dev / "serial" / "by-id" / "usb-FTDI_FT232R_USB_UART_A1B2C3-if00-port0"
    by_id.symlink_to("../../ttyUSB3")
    sysfs = fake_sysfs(tmp_path / "sys", "ttyUSB3", "16\n")
    assert tty_name(str(by_id)) == "ttyUSB3"
    assert read_latency_timer("ttyUSB3", sysfs) == 16
    # No usb-serial entry (a built-in UART, a pseudo-terminal), or no number in it: nothing.
    assert read_latency_timer("ttyS0", sysfs) is None
    fake_sysfs(sysfs, "ttyUSB4", "garbled")
    assert read_latency_timer("ttyUSB4", sysfs) is None


async def test_a_slow_timer_is_reported_once_and_its_fix_is_seen_on_reopen(
    pty: PtyLine, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger=TRANSPORT_LOG)
    tty = os.path.basename(os.path.realpath(pty.path))
    sysfs = fake_sysfs(tmp_path / "sys", tty, "16\n")
    line = SerialLine(pty.path, 9600, sysfs_root=sysfs)
    assert line.adapter is None  # nothing known before the first open
    await line.open()
    try:
        assert await exchange(line, CHECK) == CHECK_REPLY  # slow, not broken
        report = line.adapter
        assert report is not None
        assert (report.tty, report.latency_timer_ms) == (tty, 16)
        assert report.warning is not None and "16 ms" in report.warning
        assert "latency_timer" in report.warning
        await line.close()
        await line.open()  # a reconnect reads it again, and does not say it again
        assert line.adapter is not None and line.adapter.latency_timer_ms == 16
        warnings = records(caplog, logging.WARNING)
        assert len(warnings) == 1 and "latency timer is 16 ms" in warnings[0], warnings
        # The operator ran the udev rule: the next open sees 1 ms, and no warning stands.
        fake_sysfs(sysfs, tty, "1\n")
        await line.close()
        await line.open()
        assert line.adapter is not None and line.adapter.latency_timer_ms == 1
        assert line.adapter.warning is None
        assert any("latency timer is 1 ms now" in m for m in records(caplog, logging.INFO))
    finally:
        await line.close()


async def test_a_timer_of_two_ms_is_fine(pty: PtyLine, tmp_path: Path) -> None:
    tty = os.path.basename(os.path.realpath(pty.path))
    line = SerialLine(pty.path, 9600, sysfs_root=fake_sysfs(tmp_path / "sys", tty, "2"))
    await line.open()
    try:
        assert line.adapter is not None
        assert (line.adapter.latency_timer_ms, line.adapter.warning) == (2, None)
    finally:
        await line.close()


async def test_a_pseudo_terminal_refuses_low_latency_which_is_no_error(
    pty: PtyLine, caplog: pytest.LogCaptureFixture
) -> None:
    """The real /sys: a pseudo-terminal has no usb-serial entry and no TIOCSSERIAL."""
    caplog.set_level(logging.INFO, logger=TRANSPORT_LOG)
    line = SerialLine(pty.path, 9600)
    await line.open()
    try:
        assert await exchange(line, CHECK) == CHECK_REPLY
        await line.close()
        await line.open()
        report = line.adapter
        assert report is not None
        assert (report.low_latency, report.latency_timer_ms, report.warning) == (False, None, None)
        assert report.low_latency_refusal
        refused = [m for m in records(caplog, logging.INFO) if "low-latency" in m]
        assert len(refused) == 1, refused  # told once, not at every reconnect
        assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    finally:
        await line.close()


async def test_network_lines_have_no_adapter() -> None:
    assert SerialLine("socket://127.0.0.1:4001", 9600).adapter is None
