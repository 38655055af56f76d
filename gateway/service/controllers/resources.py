"""A controller's resources: position table, I/O ports, sensor logic, mode, EEPROM (§10).

Each method takes the controller (``ControllerRef``), builds its commands from the catalog's
models (never text), sends them through ``CommandRunner`` (leases and the manual's refusals
for writes) and answers a read with the resource, a write with its transaction. A read or
write that did not take effect is an error (``require_done``): 409 when the controller refused
it, 504 when its reply was lost.
"""

from __future__ import annotations

from collections.abc import Callable
from enum import StrEnum
from typing import Any

from gateway.bus.requests import TransactionResult
from gateway.errors import DeviceError, InvalidInputError, ParameterError
from gateway.protocol import commands as cmd
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.protocol.reply_values import (
    InputsWithInp,
    OutputsWithClr,
    PortByte,
    SensorLogic,
)
from gateway.service.commands import CommandRunner, require_done
from gateway.service.controllers.command_results import CommandResponse, port_json, response_of
from gateway.service.controllers.views import (
    BitView,
    IoView,
    ModeView,
    PortView,
    PositionEntry,
    SensorLogicView,
)
from gateway.service.topology import ControllerRef

__all__ = [
    "EEPROM_LOAD",
    "EEPROM_SAVE",
    "ControllerResources",
    "EepromArea",
    "value_of",
]


class EepromArea(StrEnum):
    """What an EEPROM save or load is about (§10 DW/DL, AW/AL, IW/IL)."""

    SETTINGS = "settings"  # DW / DL
    POSITIONS = "positions"  # AW / AL
    PROGRAM = "program"  # IW / IL


#: §10 DW / AW / IW: write RAM to EEPROM ('>' then ``$B#*`` when the write ends; the scheduler
#: holds the loop until then, docs/manual-notes.md); §10 DL / AL / IL: EEPROM back into RAM.
EEPROM_SAVE: dict[EepromArea, Callable[[], Command]] = {
    EepromArea.SETTINGS: cmd.save_settings,
    EepromArea.POSITIONS: cmd.save_positions,
    EepromArea.PROGRAM: cmd.save_program,
}
EEPROM_LOAD: dict[EepromArea, Callable[[], Command]] = {
    EepromArea.SETTINGS: cmd.load_settings,
    EepromArea.POSITIONS: cmd.load_positions,
    EepromArea.PROGRAM: cmd.load_program,
}


def value_of(ref: ControllerRef, result: TransactionResult, index: int = -1) -> Any:
    """The decoded value of one command of a done transaction (504 when it has none)."""
    value = require_done(ref, result).results[index].value
    if value is None:
        command = result.results[index].command.wire()
        raise DeviceError(f"controller {ref.id}: no data in the reply to {command!r}")
    return value


def _position_rule(exc: ParameterError) -> str:
    """The rule a refused table position is told with: the range of the controller's
    management as the check found it, else the rule of ``pp``'s digits."""
    found = str(exc).partition(": ")[2]
    # The management's range is checked on the whole model, whose error pydantic words
    # "Value error, ..." (a digit or type error of ``pp`` itself is worded otherwise).
    return found if found.startswith("Value error, ") else exc.rule


def _port(byte: PortByte) -> PortView:
    return PortView(**port_json(byte))


class ControllerResources:
    """Position table, I/O, sensor logic, mode and EEPROM of the gateway's controllers."""

    def __init__(self, runner: CommandRunner) -> None:
        self.runner = runner

    def _mode(self, ref: ControllerRef) -> int | None:
        return self.runner.runtime.state.controller(ref.loop, ref.body).mode

    async def _write(
        self, ref: ControllerRef, command: Command, holder: str, motor: int | None = None
    ) -> CommandResponse:
        result = await self.runner.run(ref, command, holder=holder, motor=motor)
        return response_of(ref, require_done(ref, result))

    # ------------------------------------------------------------------ position table

    async def position(self, ref: ControllerRef, number: int) -> PositionEntry:
        """Entry ``number`` of the position table (``A{pn}D``, §10 A form III)."""
        command = cmd.table_entry(number)
        value = value_of(ref, await self.runner.run(ref, command, holder=""))
        return PositionEntry(controller=ref.id, number=number, position=int(value))

    async def set_position(
        self,
        ref: ControllerRef,
        number: int,
        position: int | None,
        *,
        current: bool = False,
        motor: int | None = None,
        holder: str,
    ) -> CommandResponse:
        """Set entry ``number``: to ``position`` (``A{pn}{pp}``) or, with ``current``, to the
        current position of ``motor`` (``A{pn}``, the motor selected first).

        Signed management (mode 1; EP1 is not cached) and negative values are written with a
        sign, as the manual requires there (docs/manual-notes.md, "Positions in signed
        management carry a sign").
        """
        if current:
            command = cmd.store_position(number)
            return await self._write(ref, command, holder, motor=motor)
        signed = self._mode(ref) == 1
        fmt = PositionFormat.SIGNED if signed else None
        if position is None:  # the request's schema lets no such body through
            rule = "a position in pulses, or current: true"
            raise InvalidInputError(f"entry {number}: {rule}", field="position", rule=rule)
        pp = position
        try:
            command = cmd.set_table_entry(number, pp, fmt, signed=signed or pp < 0)
        except ParameterError as exc:  # pn is the path's, checked there: pp is `position`
            raise InvalidInputError(str(exc), field="position", rule=_position_rule(exc)) from None
        return await self._write(ref, command, holder)

    # ------------------------------------------------------------------ I/O

    async def io(self, ref: ControllerRef) -> IoView:
        """Both ports; in modes 0 and 1 with INP1/INP2 and CLR1/CLR2 (``CA``, ``COA``)."""
        mode = self._mode(ref)
        if mode is None:  # 94: the mode bits of 9, clear nothing (§10 9 form II)
            mode = int(value_of(ref, await self.runner.send(ref, [cmd.condition_bit(4)])))
        if mode in (0, 1):
            result = await self.runner.send(ref, [cmd.inputs_with_inp(), cmd.outputs_with_clr()])
            inputs = value_of(ref, result, 0)
            outputs = value_of(ref, result, 1)
            assert isinstance(inputs, InputsWithInp) and isinstance(outputs, OutputsWithClr)
            return IoView(
                controller=ref.id,
                mode=mode,
                inputs=_port(inputs.inputs),
                outputs=_port(outputs.outputs),
                inp1=inputs.inp1,
                inp2=inputs.inp2,
                clr1=outputs.clr1,
                clr2=outputs.clr2,
            )
        result = await self.runner.send(ref, [cmd.inputs(), cmd.outputs()])
        ins, outs = value_of(ref, result, 0), value_of(ref, result, 1)
        assert isinstance(ins, PortByte) and isinstance(outs, PortByte)
        return IoView(controller=ref.id, mode=mode, inputs=_port(ins), outputs=_port(outs))

    async def bit(self, ref: ControllerRef, port: str, bit: int) -> BitView:
        """One input (``C{bit}``) or output (``CO{bit}``) bit; 8, 9 = INP1/2 or CLR1/2."""
        command = cmd.input_bit(bit) if port == "inputs" else cmd.output_bit(bit)
        value = value_of(ref, await self.runner.send(ref, [command]))
        return BitView(controller=ref.id, bit=bit, on=bool(value))

    async def set_outputs(
        self, ref: ControllerRef, value: int, clr: tuple[bool, bool] | None, *, holder: str
    ) -> CommandResponse:
        """All outputs to ``value`` (``D{du}{dl}``), with ``clr`` (CLR1, CLR2) too
        (``DA{dc}{du}{dl}``, modes 0, 1)."""
        command = cmd.set_outputs(value, clr)
        return await self._write(ref, command, holder)

    async def set_output_bit(
        self, ref: ControllerRef, bit: int, on: bool, *, holder: str
    ) -> CommandResponse:
        """One output: ``D{bit}{value}B`` (0-7), ``D{clr}{value}B`` (8 CLR1, 9 CLR2)."""
        command = cmd.set_output_bit(bit, on)
        return await self._write(ref, command, holder)

    async def pulse_output(
        self, ref: ControllerRef, bit: int, time: int, *, holder: str
    ) -> CommandResponse:
        """Output ``bit`` ON for ``time`` x 100 ms (``P{bt}{time}``; it uses the timer)."""
        command = cmd.pulse_output(bit, time)
        return await self._write(ref, command, holder)

    # ------------------------------------------------------------------ sensor logic, mode

    async def sensor_logic(self, ref: ControllerRef, motor: int) -> SensorLogicView:
        """The sensor logic of ``motor`` (``EA`` with the motor selected first)."""
        value = value_of(
            ref, await self.runner.run(ref, cmd.sensor_logic(), holder="", motor=motor)
        )
        assert isinstance(value, SensorLogic)
        return SensorLogicView(
            controller=ref.id,
            motor=motor,
            step_out_sensor=value.step_out_sensor.name,
            limit=value.limit.name,
            org=value.org.name,
            emergency_stop=value.emergency_stop.name,
            inp=value.inp.name,
        )

    async def set_sensor_logic(
        self, ref: ControllerRef, motor: int, logic: SensorLogic, *, holder: str
    ) -> CommandResponse:
        """``EA{du}{dl}`` for ``motor`` (§10 EA; the EMS bit is common to both motors)."""
        command = cmd.set_sensor_logic(logic.byte)
        return await self._write(ref, command, holder, motor=motor)

    async def mode(self, ref: ControllerRef) -> ModeView:
        """The operating mode, read with ``94`` (allowed while moving, clears nothing)."""
        value = value_of(ref, await self.runner.send(ref, [cmd.condition_bit(4)]))
        return ModeView(controller=ref.id, mode=int(value))

    async def set_mode(self, ref: ControllerRef, mode: int, *, holder: str) -> CommandResponse:
        """``E{mode}`` (§10 E: not while moving)."""
        command = cmd.set_mode(mode)
        return await self._write(ref, command, holder)

    # ------------------------------------------------------------------ EEPROM

    async def eeprom(
        self, ref: ControllerRef, action: str, area: EepromArea | None, *, holder: str
    ) -> CommandResponse:
        """Save (``DW``/``AW``/``IW``), load (``DL``/``AL``/``IL``) or erase (``EE///``)."""
        if action == "erase":
            command = cmd.erase_eeprom()
        elif area is None:
            raise InvalidInputError("an EEPROM save or load names its area", field="area")
        else:
            command = (EEPROM_SAVE if action == "save" else EEPROM_LOAD)[area]()
        return await self._write(ref, command, holder)
