"""Changing the baud rate of a whole loop: every controller with ``ES``, then the port.

§10 ES: ``ES{bp}`` (0: 9,600, 1: 1,200, 2: 300 bps) sets the controller's rate and writes it
to its EEPROM at once (it survives a power cut); the ``>`` answering it goes out at the old
rate, everything after at the new one (docs/manual-notes.md "Baud rates"). A controller at
another rate than the host hears noise and answers nothing, so a loop only works when every
controller on it and the host share one rate.

``BaudChanger.change(loop, baud)`` (admin, ``POST /loops/{loop}/baud``):

1. checks before anything is sent: the loop up, every controller online (one left behind
   would be cut off the loop), none moving or running a program (ES is refused while moving,
   §10 ES), none in local control; the new rate one of the three and not the current one;
2. holds the loop: the poller and the key-switch reads pause, other requests to the loop are
   refused 409 (``ControlStates.hold``) until the change ends; stops still go out;
3. sends ``ES{bp}`` to each controller (at the old rate), then reopens the port at the new rate
   (``LineScheduler.reopen_at``) and reads each controller's status there;
4. when one does not answer at the new rate, rolls back what it can: ``ES{old}`` to every
   controller that answered at the new rate, the port back at the old rate, each read again;
   a controller that answers at neither rate is reported ``lost`` with the manual's recovery
   (docs/operations.md, "Recovering a controller").

The configuration file is not written: ``loops[].baud`` must be changed by hand to the new rate,
or the next start opens the port at the old one and finds nobody (the answer says so).
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Iterator
from typing import Literal

from pydantic import BaseModel, Field

from gateway.bus.events import BusEvent, LinkUp
from gateway.bus.requests import BusError, Outcome
from gateway.bus.scheduler import LinkState
from gateway.engine.surface import LineScheduler
from gateway.errors import ConflictError, DeviceError, InvalidInputError
from gateway.protocol import commands as cmd
from gateway.protocol.framing import BAUD_RATES
from gateway.protocol.reply_values import ProgramState
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import ControllerRef

__all__ = ["BAUD_CODES", "BaudChange", "BaudChanger", "ControllerBaud"]

#: ``ES{bp}``'s code of each rate (§10 ES).
BAUD_CODES: dict[int, cmd.BaudCode] = {9600: 0, 1200: 1, 300: 2}
#: Real seconds the loop may take to come up again after the port reopened.
REOPEN_TIMEOUT = 10.0

Result = Literal["moved", "rolled_back", "unchanged", "lost"]


class ControllerBaud(BaseModel):
    """What became of one controller."""

    controller: str
    result: Result = Field(
        description="moved: answers at the new rate; rolled_back: moved, then set back to "
        "the old rate; unchanged: never left the old rate; lost: answers at neither rate "
        "(recover it at the machine: docs/operations.md)"
    )
    baud: int | None = Field(description="the rate it answers at now; null: lost")
    frames: list[str] = Field(description="the ES frames sent to it, in order")
    detail: str | None = None


class BaudChange(BaseModel):
    """The outcome of a loop's rate change."""

    loop: str
    requested: int
    previous: int
    baud: int = Field(description="the rate the gateway's port uses now")
    outcome: Literal["done", "rolled_back", "failed"]
    controllers: list[ControllerBaud]
    configuration: str = Field(
        description="what to change in the configuration file so a restart finds the loop"
    )


class BaudChanger:
    """Moves the controllers of a loop and the gateway's port to another rate."""

    def __init__(self, runtime: Runtime) -> None:
        self.runtime = runtime
        self._busy: set[str] = set()

    async def change(self, loop: str, baud: int) -> BaudChange:
        """Move loop ``loop`` to ``baud`` (module docstring)."""
        ref = self.runtime.topology.loop(loop)
        scheduler = self.runtime.scheduler(ref.name)
        old = scheduler.timing.baud
        if baud not in BAUD_CODES:
            rates = ", ".join(str(r) for r in BAUD_RATES)
            raise InvalidInputError(
                f"{baud} bps is not a rate of the RC-233",
                field="baud",
                rule=f"one of {rates} (§10 ES)",
            )
        if baud == old:
            raise InvalidInputError(
                f"loop {ref.name} already runs at {baud} bps",
                field="baud",
                rule="a rate other than the loop's current one",
            )
        if ref.name in self._busy:
            raise ConflictError(f"the rate of loop {ref.name} is being changed", field="loop")
        self._check(ref.controllers, scheduler)
        self._busy.add(ref.name)
        # Shielded: a client that goes away mid-change must not leave the loop half moved
        # (the roll-back is part of the change); the task runs to its end either way.
        task = asyncio.ensure_future(self._held_move(ref.name, ref.controllers, old, baud))
        outcome = await asyncio.shield(task)
        now = scheduler.timing.baud
        outcome.configuration = (
            f"set baud = {now} in the [[loops]] entry of {ref.name}: the gateway does not write "
            "its configuration, and a restart at another rate finds no controller"
        )
        return outcome

    # ------------------------------------------------------------------ steps

    def _check(self, controllers: tuple[ControllerRef, ...], scheduler: LineScheduler) -> None:
        if scheduler.state is not LinkState.UP:
            raise scheduler.down_error()
        state = self.runtime.state
        for ref in controllers:
            self.runtime.control.check(ref, f"change the baud rate of loop {ref.loop}")
            ctl = state.controller(ref.loop, ref.body)
            if ctl.online is not True:
                raise ConflictError(
                    f"controller {ref.id} does not answer: every controller of the loop must "
                    "be moved together, one left at the old rate would be cut off (§10 ES)",
                    field="loop",
                )
            if ctl.moving:
                raise ConflictError(
                    f"controller {ref.id} is moving: ES is refused while a motor moves (§10 ES)",
                    field="loop",
                )
            if ctl.program is ProgramState.RUNNING:
                raise ConflictError(
                    f"the user program of {ref.id} runs: stop it first (GE)", field="loop"
                )

    async def _held_move(
        self, loop: str, controllers: tuple[ControllerRef, ...], old: int, baud: int
    ) -> BaudChange:
        scheduler = self.runtime.scheduler(loop)
        try:
            with self._held(loop):
                await self.runtime.pollers[loop].stop()
                try:
                    return await self._move(controllers, scheduler, old, baud)
                finally:
                    self.runtime.pollers[loop].start()
        finally:
            self._busy.discard(loop)

    @contextlib.contextmanager
    def _held(self, loop: str) -> Iterator[None]:
        control = self.runtime.control
        control.hold(loop, "its baud rate is being changed")
        self.runtime.key_switches.pause(loop)
        try:
            yield
        finally:
            self.runtime.key_switches.resume(loop)
            control.release(loop)

    async def _move(
        self,
        controllers: tuple[ControllerRef, ...],
        scheduler: LineScheduler,
        old: int,
        baud: int,
    ) -> BaudChange:
        frames: dict[str, list[str]] = {c.id: [] for c in controllers}
        for ref in controllers:
            await self._send_es(scheduler, ref, baud, frames)
        await self._reopen(scheduler, baud)
        answered = {ref.id: await self._answers(scheduler, ref) for ref in controllers}
        loop = controllers[0].loop
        if all(answered.values()):
            entries = [
                ControllerBaud(controller=c.id, result="moved", baud=baud, frames=frames[c.id])
                for c in controllers
            ]
            return BaudChange(
                loop=loop, requested=baud, previous=old, baud=baud, outcome="done",
                controllers=entries, configuration="",
            )  # fmt: skip
        # Roll back: the ones at the new rate go back to the old one, then the port.
        moved = [c for c in controllers if answered[c.id]]
        for ref in moved:
            await self._send_es(scheduler, ref, old, frames)
        await self._reopen(scheduler, old)
        entries = []
        for ref in controllers:
            back = await self._answers(scheduler, ref)
            if back:
                result: Result = "rolled_back" if answered[ref.id] else "unchanged"
                entries.append(
                    ControllerBaud(
                        controller=ref.id, result=result, baud=old, frames=frames[ref.id]
                    )
                )
            else:
                entries.append(
                    ControllerBaud(
                        controller=ref.id,
                        result="lost",
                        baud=None,
                        frames=frames[ref.id],
                        detail=f"answers neither at {baud} nor at {old} bps: recover it at the "
                        "machine (body switch F, '/' at 9600 bps, §10 ES; erases its EEPROM)",
                    )
                )
        lost = any(e.result == "lost" for e in entries)
        return BaudChange(
            loop=loop, requested=baud, previous=old, baud=old,
            outcome="failed" if lost else "rolled_back", controllers=entries, configuration="",
        )  # fmt: skip

    async def _send_es(
        self, scheduler: LineScheduler, ref: ControllerRef, baud: int, frames: dict[str, list[str]]
    ) -> None:
        command = cmd.set_baud_rate(BAUD_CODES[baud])
        # As asked until the result tells what was written (a loop down before it says none).
        frames[ref.id].append(f"{ref.series.value}{ref.body}{command.wire()}")
        with contextlib.suppress(BusError):  # whether it took is what the next read tells
            result = await scheduler.submit(ref.body, command)
            if result.results and result.results[-1].frame:
                frames[ref.id][-1] = result.results[-1].written
            if result.outcome is Outcome.NOT_DONE and result.results:
                frames[ref.id][-1] += f" ({result.results[-1].kind.value})"

    async def _reopen(self, scheduler: LineScheduler, baud: int) -> None:
        """Reopen the port at ``baud`` and wait until the loop is up again (some controller
        answered a probe there), or ``REOPEN_TIMEOUT``: then nobody answers at that rate."""
        up = asyncio.Event()

        def seen(event: BusEvent) -> None:
            if isinstance(event, LinkUp):
                up.set()

        unsubscribe = scheduler.events.subscribe(seen)
        try:
            scheduler.reopen_at(baud)
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(up.wait(), REOPEN_TIMEOUT)
        finally:
            unsubscribe()

    async def _answers(self, scheduler: LineScheduler, ref: ControllerRef) -> bool:
        """Whether ``ref`` answers its status query (``""``) at the port's rate now."""
        if scheduler.state is not LinkState.UP:
            return False
        try:
            result = await scheduler.submit(ref.body, cmd.status())
        except (BusError, DeviceError):
            return False
        return result.ok
