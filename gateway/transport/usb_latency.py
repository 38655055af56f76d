"""How promptly a local serial adapter hands received bytes over: the low-latency flag and an
FTDI adapter's latency timer.

A USB-serial adapter does not pass each received byte up at once. An FTDI chip (driver
``ftdi_sio``) holds them until its buffer fills or its latency timer runs out: 16 ms by
default. An RC-233 reply at 9600 bps takes 5-10 ms on the wire, so a 16 ms timer can more
than double every exchange, and nothing reports an error: the line is just slow. Two
settings fix it:

* the tty's ``ASYNC_LOW_LATENCY`` flag (``TIOCSSERIAL``; pyserial's
  ``set_low_latency_mode``), set here on every open: ``ftdi_sio`` then uses 1 ms (and its
  ``latency_timer`` reads 1, so the flag is set before the timer is read); drivers without
  ``TIOCSSERIAL`` (a pseudo-terminal) refuse it, which is no error;
* the timer itself, ``/sys/bus/usb-serial/devices/<tty>/latency_timer`` (ms), which only root
  may write: deploy/udev/99-rc233-ftdi-latency.rules sets it to 1 when the adapter appears.
  It is read here on every open and reported (log, the loop's view, a metric) when it is
  above ``LATENCY_TIMER_LIMIT_MS``.

Everything here blocks (an ``ioctl``, a file read): ``SerialLine`` calls it in the worker
thread that opens the port.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = [
    "LATENCY_TIMER_LIMIT_MS",
    "SYSFS_ROOT",
    "AdapterNotes",
    "AdapterReport",
    "check_adapter",
    "read_latency_timer",
    "set_low_latency",
    "tty_name",
]

#: Where the kernel's sysfs is mounted; tests pass a directory of their own.
SYSFS_ROOT = Path("/sys")
#: Above this (ms) the timer adds a noticeable share to an exchange of 5-30 ms: warn. 1 ms is
#: what the udev rule sets; 2 ms is still fine; the driver's default 16 ms is not.
LATENCY_TIMER_LIMIT_MS = 2


@dataclass(frozen=True)
class AdapterReport:
    """What the last open of a device path learned about its adapter.

    ``tty`` is the kernel's name of the device (``ttyUSB0``: the configured path with its
    symbolic links resolved); ``low_latency`` whether the driver took the low-latency flag;
    ``latency_timer_ms`` the adapter's latency timer, ``None`` when the device has none (not a
    USB-serial adapter, or a driver without the setting); ``low_latency_refusal`` why the
    driver refused the flag.
    """

    tty: str
    low_latency: bool
    latency_timer_ms: int | None
    low_latency_refusal: str | None = None

    @property
    def warning(self) -> str | None:
        """What to tell the operator, or ``None`` when the adapter passes bytes on promptly."""
        timer = self.latency_timer_ms
        if timer is None or timer <= LATENCY_TIMER_LIMIT_MS:
            return None
        return (
            f"{self.tty}: the USB adapter's latency timer is {timer} ms (above "
            f"{LATENCY_TIMER_LIMIT_MS} ms): received bytes wait up to {timer} ms, which slows "
            f"every exchange; set it to 1 (deploy/udev/99-rc233-ftdi-latency.rules, or "
            f"`echo 1 > /sys/bus/usb-serial/devices/{self.tty}/latency_timer` as root)"
        )


def tty_name(device: str) -> str:
    """The kernel's name of ``device``: ``/dev/serial/by-id/usb-FTDI...`` -> ``ttyUSB0``."""
    return os.path.basename(os.path.realpath(device))


def read_latency_timer(tty: str, sysfs_root: Path = SYSFS_ROOT) -> int | None:
    """The latency timer (ms) of USB-serial device ``tty``; ``None`` when it has none or the
    file does not hold a number (nothing to report, nothing to warn about)."""
    path = sysfs_root / "bus" / "usb-serial" / "devices" / tty / "latency_timer"
    try:
        text = path.read_text(encoding="ascii", errors="replace")
    except OSError:  # not a USB-serial device, or its driver has no timer
        return None
    try:
        return int(text.strip())
    except ValueError:
        return None


def set_low_latency(port: Any) -> str | None:
    """Set the low-latency flag on the open pyserial ``port``; ``None`` if the driver took
    it, else why not (pyserial raises ``ValueError`` around the ioctl's ``OSError``)."""
    setter = getattr(port, "set_low_latency_mode", None)
    if setter is None:  # pyserial offers it on Linux only
        return "this platform has no low-latency flag"
    try:
        setter(True)
    except (OSError, ValueError) as exc:
        return str(exc)
    return None


def check_adapter(port: Any, device: str, sysfs_root: Path = SYSFS_ROOT) -> AdapterReport:
    """Set the low-latency flag on ``port`` (opened from ``device``) and read its adapter's
    latency timer: what the operator needs to know about how promptly bytes come in."""
    tty = tty_name(device)
    refusal = set_low_latency(port)
    return AdapterReport(
        tty=tty,
        low_latency=refusal is None,
        latency_timer_ms=read_latency_timer(tty, sysfs_root),
        low_latency_refusal=refusal,
    )


class AdapterNotes:
    """Logs what the opens of one line learn about its adapter, each finding once: a line
    that reconnects every few seconds must not fill the log with the same words."""

    def __init__(self, url: str, log: logging.Logger) -> None:
        self.url = url
        self.log = log
        self._refusal_told = False
        self._warned: str | None = None

    def tell(self, report: AdapterReport | None) -> None:
        """Log ``report``'s news: a refused flag (once), a slow timer (when it becomes
        slow), the timer put right (when it does)."""
        if report is None:
            return
        if report.low_latency_refusal is not None and not self._refusal_told:
            # A pseudo-terminal (the simulator) refuses: that is no fault, only information.
            self._refusal_told = True
            self.log.info(
                "%s: the driver does not take the low-latency flag (%s)",
                self.url,
                report.low_latency_refusal,
            )
        warning = report.warning
        if warning is not None and warning != self._warned:
            self.log.warning("%s: %s", self.url, warning)
        elif warning is None and self._warned is not None:
            self.log.info(
                "%s: the adapter's latency timer is %s ms now", self.url, report.latency_timer_ms
            )
        self._warned = warning
