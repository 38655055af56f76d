"""Controllers and loops as clients use them: views, any command, raw text, trace.

``ControllerService(gateway, leases, operations)`` is what the controller and loop routes call:

* views of loops and controllers from the state cache (no line traffic), or read now with
  ``fresh`` (the poller's status reads: ``""``, ``94``, ``97``, ``61``, ``62``, ``GSS``);
* ``command``: one command model of the catalog (the typed body of ``/commands``), checked by
  ``CommandRunner`` (leases, the manual's refusals) and answered with its typed reply;
* ``raw``: command text, parsed through the catalog first (text that fits no form is refused
  with the reason and never reaches the wire), then sent like ``command``;
* the line trace of a loop (off until switched on; bounded).

The resources of a controller (position table, I/O, sensor logic, mode, EEPROM) are
``resources`` (``ControllerResources``), its user program ``programs`` (``ProgramService``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

from pydantic import BaseModel, Field

from gateway.bus.scheduler import LinkState
from gateway.bus.trace import TraceRecord
from gateway.errors import InvalidInputError, NotFoundError
from gateway.protocol import commands
from gateway.protocol.command_text import parse
from gateway.protocol.models import Command
from gateway.service.commands import CommandRunner
from gateway.service.control import ControlView
from gateway.service.controllers.command_results import CommandResponse, response_of
from gateway.service.controllers.programs import ProgramService
from gateway.service.controllers.resources import ControllerResources
from gateway.service.presend import LeaseCheck
from gateway.service.runtime.runtime import Runtime
from gateway.service.topology import ControllerRef
from gateway.service.views import ControllerView, LoopView, controller_view, loop_view, wall_time

__all__ = ["FRESH_READS", "ControllerService", "TraceLine", "TraceView"]

#: What ``?fresh=true`` reads: status (moving, errors), mode (94: clears nothing and is allowed
#: while moving, §10 9 form II), the selected motor (97), both positions, the program state.
FRESH_READS: tuple[Command, ...] = (
    commands.status(),
    commands.condition_bit(4),
    commands.condition_bit(7),
    commands.position(1),
    commands.position(2),
    commands.program_state(),
)


class TraceLine(BaseModel):
    """One traced chunk of a loop's line."""

    time: float | None = Field(description="seconds since the epoch")
    direction: str = Field(description="tx, rx, discard or note")
    controller: str | None
    text: str = Field(description="the bytes as ASCII (CR as \\r) or hex")
    note: str


class TraceView(BaseModel):
    """The line trace of a loop: whether it is on, for which controllers, and its records."""

    loop: str
    enabled: bool
    controllers: list[str]
    hex: bool
    lines: list[TraceLine]


class ControllerService:
    """Controllers and loops of ``gateway`` as the API shows them."""

    def __init__(self, runtime: Runtime, leases: LeaseCheck, operations: Any = None) -> None:
        self.runtime = runtime
        self.leases = leases
        self.operations = operations
        self.runner = CommandRunner(runtime, leases)
        self.resources = ControllerResources(self.runner)
        self.programs = ProgramService(self.runner)

    # ------------------------------------------------------------------ resolving

    def controller(self, ident: str) -> ControllerRef:
        """The controller with id (``loop.body``) or name ``ident`` (404 otherwise)."""
        return self.runtime.topology.controller(ident)

    def on_loop(self, loop: str, ident: str) -> ControllerRef:
        """A controller of ``loop`` by body number, id or name (404 otherwise)."""
        ref = self.runtime.topology.loop(loop)
        for ctl in ref.controllers:
            if ident in (ctl.body, ctl.id, ctl.name):
                return ctl
        raise NotFoundError(
            "controller",
            f"{ident} on loop {ref.name}",
            known=tuple(c.body for c in ref.controllers),
        )

    # ------------------------------------------------------------------ views

    def controllers(self) -> list[ControllerView]:
        """Every controller, as cached."""
        state = self.runtime.state
        return [
            controller_view(ref, state.controller(ref.loop, ref.body), self._control(ref))
            for ref in self.runtime.topology.controllers()
        ]

    def view(self, ident: str) -> ControllerView:
        """One controller, as cached."""
        ref = self.controller(ident)
        state = self.runtime.state.controller(ref.loop, ref.body)
        return controller_view(ref, state, self._control(ref))

    def _control(self, ref: ControllerRef) -> ControlView:
        return self.runtime.control.view(ref)

    async def fresh_view(self, ident: str) -> ControllerView:
        """One controller after reading its status now (``FRESH_READS``)."""
        ref = self.controller(ident)
        await self.runner.send(ref, FRESH_READS)
        return self.view(ref.id)

    def loops(self) -> list[LoopView]:
        """Every loop."""
        return [self.loop(ref.name) for ref in self.runtime.topology.loops()]

    def loop(self, name: str) -> LoopView:
        """One loop: link state and queue depth now, the scheduler's counters now."""
        ref = self.runtime.topology.loop(name)
        scheduler = self.runtime.scheduler(ref.name)
        counters = dataclasses.asdict(scheduler.snapshot())
        state = replace(
            self.runtime.state.loop(ref.name),
            up=scheduler.state is LinkState.UP,
            cause=scheduler.cause or None,
            queue_depth=scheduler.queue_depth,
            counters={k: v for k, v in counters.items() if isinstance(v, int | float)},
        )
        settings = ref.settings
        # The rate the port uses now: POST /loops/{loop}/baud changes it at run time.
        baud = scheduler.timing.baud
        adapter = scheduler.transport.adapter
        return loop_view(ref.name, settings.port, baud, list(ref.bodies), state, adapter)

    # ------------------------------------------------------------------ commands

    async def command(
        self, ident: str, command: Command, *, holder: str, motor: int | None = None
    ) -> CommandResponse:
        """Send one command model to controller ``ident``; its typed reply."""
        ref = self.controller(ident)
        result = await self.runner.run(ref, command, holder=holder, motor=motor)
        return response_of(ref, result)

    def parse_raw(self, text: str) -> Command:
        """The command model of raw ``text``; 422 with the reason when it fits no form."""
        try:
            command = parse(text)
        except InvalidInputError as exc:
            field = "text" if exc.field in (None, "text") else f"text.{exc.field}"
            raise InvalidInputError(str(exc), field=field, rule=exc.rule) from None
        self.runner.checks.refuse_unsendable(command, field="text")
        return command

    async def raw(
        self, loop: str, controller: str, text: str, *, motor: int | None, holder: str
    ) -> CommandResponse:
        """Parse ``text`` through the catalog and send it to ``controller`` of ``loop`` (with
        ``motor`` selected first when given)."""
        ref = self.on_loop(loop, controller)
        command = self.parse_raw(text)
        result = await self.runner.run(ref, command, holder=holder, motor=motor, field="text")
        return response_of(ref, result)

    # ------------------------------------------------------------------ trace

    def trace(self, loop: str, controller: str | None = None) -> TraceView:
        """The trace of ``loop`` (of one controller: body number, id or name)."""
        ref = self.runtime.topology.loop(loop)
        trace = self.runtime.scheduler(ref.name).trace
        body = self.on_loop(ref.name, controller).body if controller else None
        return TraceView(
            loop=ref.name,
            enabled=trace.all,
            controllers=sorted(f"{ref.name}.{b}" for b in trace.bodies),
            hex=trace.hex_mode,
            lines=[_line(ref.name, r, trace.hex_mode) for r in trace.records(body)],
        )

    def set_trace(
        self,
        loop: str,
        *,
        enabled: bool,
        controllers: Sequence[str] = (),
        hex_mode: bool = False,
        clear: bool = False,
    ) -> TraceView:
        """Switch the trace of ``loop`` (whole loop, or ``controllers`` in addition); the
        trace afterwards."""
        ref = self.runtime.topology.loop(loop)
        bodies = {self.on_loop(ref.name, c).body for c in controllers}
        trace = self.runtime.scheduler(ref.name).trace
        trace.enable(enabled, hex_mode=hex_mode)
        for body in set(trace.bodies) - bodies:
            trace.enable_body(body, False)
        for body in bodies:
            trace.enable_body(body, True)
        if clear:
            trace.clear()
        return self.trace(ref.name)


def _line(loop: str, record: TraceRecord, hex_mode: bool) -> TraceLine:
    return TraceLine(
        time=wall_time(record.time),
        direction=record.direction.value,
        controller=f"{loop}.{record.body}" if record.body is not None else None,
        text=record.hex() if hex_mode else record.ascii(),
        note=record.note,
    )
