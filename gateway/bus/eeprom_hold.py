"""Holding the line while a controller writes its EEPROM (§10 AW, DW, IW, EE///).

``AW``, ``DW`` and ``IW`` answer '>' at once and ``$B#*`` CR when the write ends; ``EE///``
answers '>' and erases for 10-20 s in silence, ignoring every command, then sends ``$B#*`` CR.
The ``$B#*`` comes whenever the write ends, and on the current loop two controllers talking at
once garble each other (one receive line, §3-I, §5): so nothing else is sent on the loop until
it has come or the documented time has run out (``LoopConfig.eeprom_write_hold``,
``erase_hold``). A stop still goes out meanwhile (DESIGN invariant 8): a stop outranks the
risk of a garbled reply, and a stop's reply that is garbled is simply sent again.
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

from gateway.bus.exchange import LineExchange
from gateway.bus.link import LinkLost
from gateway.bus.requests import Outcome
from gateway.protocol.commands import ERASE_EEPROM
from gateway.protocol.models import Command

__all__ = ["hold_for_write"]


async def hold_for_write(
    core: LineExchange, body: str, command: Command, mark: int, seen: dict[str, Any]
) -> Outcome:
    """Wait for a ``$B#*`` of ``body`` after the ``mark``-th; DONE when it came, else UNKNOWN.

    ``seen["eeprom_done"]`` records whether it came. Queued stops are served meanwhile.
    """
    erase = command.form is ERASE_EEPROM
    hold = core.config.erase_hold if erase else core.config.eeprom_write_hold
    event_loop = asyncio.get_running_loop()
    deadline = event_loop.time() + core.timing.real(hold)
    if erase:  # §10 EE///: deaf and silent while erasing; its silence is no dead line
        core.health.deaf(body, core.clock() + core.timing.real(hold))
    try:
        while core.eeprom_done.get(body, 0) <= mark:
            left = deadline - event_loop.time()
            if left <= 0:
                break
            waits = [
                asyncio.ensure_future(core.eeprom_event.wait()),
                asyncio.ensure_future(core.stops.wait()),
                asyncio.ensure_future(core.link.lost.wait()),
            ]
            try:
                await asyncio.wait(waits, timeout=left, return_when=asyncio.FIRST_COMPLETED)
            finally:
                for task in waits:
                    task.cancel()
                for task in waits:
                    with contextlib.suppress(asyncio.CancelledError):
                        await task
            if core.link.lost_cause is not None:
                raise LinkLost(core.link.lost_cause)
            if core.stops.waiting():
                await core.stops.send_queued()
    finally:
        core.health.deaf(body, None)
    done = core.eeprom_done.get(body, 0) > mark
    seen["eeprom_done"] = done
    return Outcome.DONE if done else Outcome.UNKNOWN
