"""A controller's user program (§10 I ... IW, chapters 11-12): upload, read back, run, inspect.

Upload validates the text with ``parse_program`` first (a broken rule is a 422 naming the
step, the field and the rule, and nothing is sent), then ``scheduler.upload_program`` sends
``I`` and the text as one transaction. Reading back is ``IR``. Running, pausing, resuming and
ending are ``G``/``G{lb}``, ``GS``, ``GC``, ``GE``; ``GES`` (end and stop the motor) goes at
stop priority. Status is ``GSS`` and ``GN`` in one transaction (``GSS`` reports 'E' once; the
state cache latches it as a program error). Buffers and counters are ``GR``/``GW``, autostart
``GA``/``GAS``/``GAR``.
"""

from __future__ import annotations

from gateway.errors import InvalidInputError, ParameterError
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.program import Program, parse_program
from gateway.protocol.reply_values import PortByte, ProgramState
from gateway.service.commands import CommandRunner, require_done
from gateway.service.controllers.command_results import CommandResponse, port_json, response_of
from gateway.service.controllers.resources import value_of
from gateway.service.controllers.views import (
    PortView,
    ProgramData,
    ProgramStatus,
    ProgramText,
)
from gateway.service.topology import ControllerRef

__all__ = ["BUFFERS", "COUNTERS", "ProgramService"]

#: The data buffers and counters of a program (§10 GR, GW).
BUFFERS: tuple[cmd.ProgramBuffer, ...] = ("A", "B", "C", "D", "E", "F")
COUNTERS = (1, 2)

_STATE_NAMES = {
    ProgramState.RUNNING: "running",
    ProgramState.ENDED: "ended",
    ProgramState.PAUSED: "paused",
    ProgramState.ERROR: "error",
}


def _info(ref: ControllerRef, text: str) -> ProgramText:
    try:
        program = parse_program(text)
        steps: int | None = program.step_count
        size = program.size_bytes
    except InvalidInputError:  # a program the gateway would not upload: shown as it is
        steps, size = None, len(text)
    return ProgramText(controller=ref.id, text=text, bytes=size, steps=steps)


class ProgramService:
    """The user programs of the gateway's controllers."""

    def __init__(self, runner: CommandRunner) -> None:
        self.runner = runner

    async def _do(self, ref: ControllerRef, command: Command, holder: str) -> CommandResponse:
        result = await self.runner.run(ref, command, holder=holder)
        return response_of(ref, require_done(ref, result))

    def check(self, text: str) -> Program:
        """``text`` parsed (chapters 11-12); a broken rule raises naming the step and the
        field (``text``, ``text.<the statement's field>``). Nothing is sent."""
        try:
            return parse_program(text)
        except InvalidInputError as exc:
            exc.field = "text" if exc.field in (None, "text") else f"text.{exc.field}"
            raise

    async def upload(self, ref: ControllerRef, text: str, *, holder: str) -> CommandResponse:
        """Validate ``text`` (chapters 11-12) and upload it (``I`` + text + CR)."""
        program = self.check(text)
        command = cmd.upload_program()
        self.runner.checks.control(ref, [command])
        self.runner.checks.lease(ref, [command], holder)
        self.runner.checks.state(ref, [command])
        scheduler = self.runner.runtime.scheduler(ref.loop)
        result = await scheduler.upload_program(ref.body, program)
        response = response_of(ref, require_done(ref, result))
        response.frames = [*response.frames, program.text()]
        return response

    async def text(self, ref: ControllerRef) -> ProgramText:
        """The program in RAM, read back with ``IR``."""
        value = value_of(ref, await self.runner.send(ref, [cmd.program_text()]))
        return _info(ref, str(value))

    async def run(self, ref: ControllerRef, label: str | None, *, holder: str) -> CommandResponse:
        """``G`` (from the start) or ``G{lb}`` (from the statement after ``/G{lb}``), then
        ``GSS``: its value ('1' running, '0' ended, 'E' ended by an error) is the answer."""
        # Built from the model, never from text: "G" + "S" would read as GS (pause).
        try:
            command = cmd.run_program(label)
        except ParameterError as exc:
            raise InvalidInputError(str(exc), field="label", rule=exc.rule) from None
        # GSS right after, in the same transaction: a G the device refuses (no program, a
        # label it lacks) is still answered '>' (§9-1 注意); the state shows whether it runs.
        result = await self.runner.run(ref, [command, cmd.program_state()], holder=holder)
        return response_of(ref, require_done(ref, result))

    async def pause(self, ref: ControllerRef, *, holder: str) -> CommandResponse:
        """``GS``: pause at the next statement boundary (resume with ``GC``)."""
        return await self._do(ref, cmd.pause_program(), holder)

    async def resume(self, ref: ControllerRef, *, holder: str) -> CommandResponse:
        """``GC``: continue a program paused with ``GS``."""
        return await self._do(ref, cmd.resume_program(), holder)

    async def stop(self, ref: ControllerRef, mode: str, *, holder: str) -> CommandResponse:
        """``GE`` (end at a statement boundary) or ``GES`` (at once, stopping the motor).

        Never refused by a lease: whoever holds the controller, anyone may stop a program, as
        anyone may stop a motion (a stop must never wait for the holder).
        """
        if mode == "immediate":
            scheduler = self.runner.runtime.scheduler(ref.loop)
            result = await scheduler.stop(ref.body, cmd.end_program_now())
            return response_of(ref, require_done(ref, result))
        return await self._do(ref, cmd.end_program(), holder)

    async def status(self, ref: ControllerRef) -> ProgramStatus:
        """``GSS`` and ``GN``."""
        result = await self.runner.send(ref, [cmd.program_state(), cmd.next_step()])
        state, step = value_of(ref, result, 0), value_of(ref, result, 1)
        assert isinstance(state, ProgramState)
        return ProgramStatus(
            controller=ref.id,
            state=state.value,
            state_name=_STATE_NAMES[state],
            step=int(step),
        )

    async def data(self, ref: ControllerRef) -> ProgramData:
        """Every data buffer and counter (``GR{bf}``, ``GR{ct}``), in one transaction."""
        commands = [cmd.program_buffer(b) for b in BUFFERS] + [
            cmd.program_counter(c) for c in COUNTERS
        ]
        result = await self.runner.send(ref, commands)
        values = [value_of(ref, result, i) for i in range(len(commands))]
        buffers: dict[str, PortView] = {}
        for name, value in zip(BUFFERS, values, strict=False):
            assert isinstance(value, PortByte)
            buffers[name] = PortView(**port_json(value))
        counters = {str(c): int(v) for c, v in zip(COUNTERS, values[len(BUFFERS) :], strict=True)}
        return ProgramData(controller=ref.id, buffers=buffers, counters=counters)

    async def set_buffer(
        self, ref: ControllerRef, buffer: cmd.ProgramBuffer, value: int, *, holder: str
    ) -> CommandResponse:
        """``GW{bf}{du}{dl}``: one data buffer byte."""
        command = cmd.set_program_buffer(buffer, value)
        result = await self.runner.run(ref, command, holder=holder)
        return response_of(ref, require_done(ref, result))

    async def set_counter(
        self, ref: ControllerRef, counter: int, value: int, *, holder: str
    ) -> CommandResponse:
        """``GW{ct}{dt}``: one counter."""
        command = cmd.set_program_counter(counter, value)
        result = await self.runner.run(ref, command, holder=holder)
        return response_of(ref, require_done(ref, result))

    async def autostart(self, ref: ControllerRef) -> bool:
        """``GA``: whether the program starts at power-on."""
        value = value_of(ref, await self.runner.run(ref, cmd.program_autostart(), holder=""))
        return bool(value)

    async def set_autostart(
        self, ref: ControllerRef, enabled: bool, *, holder: str
    ) -> CommandResponse:
        """``GAS`` / ``GAR`` (written to the EEPROM at once, §10 GA)."""
        return await self._do(ref, cmd.set_program_autostart(enabled), holder)
