"""What the loops' ports must be on this machine: serial ports, each used by one loop.

Checked by ``check-config`` and ``serve`` before anything starts (the raw values of the file,
so these problems are listed beside the schema's):

* each ``loops[i].port`` is a well-formed URL (``LineKind.of``);
* a device path that exists is a terminal: a character device is not enough (``/dev/null``,
  ``/dev/zero`` and ``/dev/random`` are character devices; the gateway would write its frames
  into them and wait for replies that never come). It is opened for reading and writing,
  non-blocking (a serial port waiting for its carrier would otherwise hold the check) and
  without becoming the controlling terminal, asked ``isatty`` and closed: nothing is read,
  written or set. Opening it is also what tells whether this user may use it;
* a device path that does not exist is a warning, not a problem: a USB adapter unplugged at
  boot is one loop down, not a gateway that cannot start. ``serve`` starts that loop down with
  the cause and opens it, with back-off, as soon as the device appears (``--strict``:
  ``check-config`` counts it as a problem);
* no two loops reach one line (``line_identity``: symbolic links resolved, network URLs
  compared normalised): two schedulers on one loop would break "one command in flight".
"""

from __future__ import annotations

import errno
import os
import stat
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from gateway.transport import LineKind
from gateway.transport.factory import line_identity

__all__ = ["PortFindings", "port_findings"]


@dataclass
class PortFindings:
    """What the ports of a file's loops hold: problems (nothing starts) and warnings."""

    problems: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def _opened_is_tty(path: str) -> bool:
    """Whether ``path`` is a terminal, asked of the open device (``OSError`` if it cannot be
    opened). Non-blocking and no controlling terminal: opening never waits and changes
    nothing of this process or the port."""
    flags = os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    fd = os.open(path, flags)
    try:
        return os.isatty(fd)
    finally:
        os.close(fd)


def _device_finding(where: str, url: str, found: PortFindings) -> None:
    try:
        mode = os.stat(url).st_mode
    except FileNotFoundError as exc:
        found.warnings.append(
            f"{where}: {url} does not exist yet ({exc.strerror}): the loop starts down and "
            "is opened as soon as the device appears"
        )
        return
    except OSError as exc:
        found.problems.append(f"{where}: {url}: {exc.strerror}")
        return
    if not stat.S_ISCHR(mode):
        found.problems.append(f"{where}: {url} is not a serial device (a character device)")
        return
    try:
        terminal = _opened_is_tty(url)
    except OSError as exc:
        if exc.errno in (errno.EACCES, errno.EPERM):
            found.problems.append(
                f"{where}: {url} cannot be opened for reading and writing by this user"
            )
        else:
            found.problems.append(f"{where}: {url}: cannot be opened ({exc.strerror})")
        return
    if not terminal:
        found.problems.append(
            f"{where}: {url} is a character device but not a terminal (not a serial port)"
        )


def port_findings(loops: Any) -> PortFindings:
    """The problems and warnings of the ports of ``loops`` (the file's raw ``loops`` value)."""
    found = PortFindings()
    if not isinstance(loops, Sequence) or isinstance(loops, str):
        return found  # the schema names it
    claimed: dict[str, str] = {}
    for i, loop in enumerate(loops):
        if not isinstance(loop, Mapping) or not isinstance(loop.get("port"), str):
            continue  # the schema names it
        where, url = f"loops[{i}].port", str(loop["port"])
        try:
            kind = LineKind.of(url)
        except ValueError as exc:
            found.problems.append(f"{where}: {exc}")
            continue
        if kind is LineKind.DEVICE:
            _device_finding(where, url, found)
        line = line_identity(url)
        if line in claimed:
            same = "" if line == url else f" ({line})"
            found.problems.append(
                f"{where}: {url}{same} is already the port of {claimed[line]}: one loop a line"
            )
        else:
            claimed[line] = f"loops[{i}]"
    return found
