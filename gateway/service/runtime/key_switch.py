"""Reads the key-switch inputs of local control (``local_input``) once a poll period.

The poller reads no general input, so this service-level task submits ``C`` (§10 C form I:
the general input port as two hex digits, bit 0-7, 1 = ON; allowed in every mode and while a
motor moves) to each controller with a key switch, through the loop's scheduler at poll
priority: it waits behind every client request and stop, and the scheduler's queue keeps one
command in flight per loop. The period is the loop's ``poll.idle_period`` (device seconds,
host seconds through the loop's time scale, as the poller's).

A read that fails (loop down, time-out, '?') changes nothing: the last reading stands, and a
controller that does not answer is offline, where every motion is refused anyway. A switch
never read counts as local (``ControlStates``).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging

from gateway.bus.requests import BusError, Priority
from gateway.bus.scheduler import LinkState
from gateway.engine.surface import LineScheduler
from gateway.protocol import commands as cmd
from gateway.protocol.reply_values import PortByte
from gateway.service.control import ControlStates, local_input_of
from gateway.service.topology import ControllerRef, Topology

__all__ = ["KeySwitchReader"]

log = logging.getLogger("gateway.service")

_READ = cmd.inputs()


class KeySwitchReader:
    """One task per loop that has controllers with a key switch."""

    def __init__(
        self, topology: Topology, control: ControlStates, schedulers: dict[str, LineScheduler]
    ) -> None:
        self.topology, self.control, self.schedulers = topology, control, schedulers
        self._tasks: list[asyncio.Task[None]] = []
        self._paused: set[str] = set()

    def pause(self, loop: str) -> None:
        """Read nothing on ``loop`` until ``resume`` (its rate is being changed)."""
        self._paused.add(loop)

    def resume(self, loop: str) -> None:
        """Read ``loop`` again."""
        self._paused.discard(loop)

    def start(self) -> None:
        """Start reading (nothing to do when no controller has a key switch)."""
        by_loop: dict[str, list[ControllerRef]] = {}
        for ref, _ in self.control.switches():
            by_loop.setdefault(ref.loop, []).append(ref)
        for loop, refs in by_loop.items():
            task = asyncio.create_task(self._run(loop, refs), name=f"key-switch-{loop}")
            self._tasks.append(task)

    async def stop(self) -> None:
        """Stop reading."""
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self._tasks.clear()

    async def read(self, ref: ControllerRef) -> bool:
        """Read the key switch of ``ref`` now; True when the read succeeded."""
        bits = local_input_of(self.topology, ref)
        if bits is None:
            return False
        scheduler = self.schedulers[ref.loop]
        if scheduler.state is not LinkState.UP:
            return False
        try:
            result = await scheduler.submit(ref.body, _READ, priority=Priority.POLL)
        except BusError as exc:
            log.debug("key switch of %s not read: %s", ref.id, exc)
            return False
        value = result.value
        if not result.ok or not isinstance(value, PortByte):
            return False
        self.control.set_input(ref, value[bits.bit])
        return True

    async def _run(self, loop: str, refs: list[ControllerRef]) -> None:
        scheduler = self.schedulers[loop]
        period = self.topology.loop(loop).settings.poll.idle_period / scheduler.config.time_scale
        while True:
            for ref in refs if loop not in self._paused else ():
                try:
                    await self.read(ref)
                except asyncio.CancelledError:
                    raise
                except Exception:  # a defect must not end the lock-out's reading for good
                    log.exception("key switch of %s: read failed", ref.id)
            await asyncio.sleep(period)
