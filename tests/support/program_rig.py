"""A simulated controller driven directly, to run the manual's program examples."""

from __future__ import annotations

from collections.abc import Callable

from tests.sim.direct import Direct

ACK = b">"
CH10_GN = "/7/T100/S/END"


def run_until(direct: Direct, done: Callable[[], bool], limit: float, step: float = 0.01) -> float:
    """Move the clock in small steps until ``done()``; the time it became true."""
    while direct.now < limit:
        direct.run(direct.now + step)
        if done():
            return direct.now
    raise AssertionError(f"not done by {limit} s")


def gn(direct: Direct) -> int:
    reply = direct.cmd("GN")
    assert reply[:3] == b">$1" and reply[-1:] == b"\r", reply
    return int(reply[3:-1])


def position(direct: Direct) -> int:
    reply = direct.cmd("6")
    assert reply[:3] == b">$1", reply
    return int(reply[3:-1])


def start(program: str) -> Direct:
    direct = Direct()
    assert direct.upload(program) == ACK + ACK
    assert direct.cmd("G") == ACK
    return direct
