"""Constructors of the status, I/O, framing, line and user-program forms (§10)."""

from __future__ import annotations

from gateway.protocol.commands.base import BaudCode, ProgramBuffer, build, on_off
from gateway.protocol.models import Command

__all__ = [
    "baud_rate",
    "checksum",
    "condition",
    "condition_bit",
    "cr_after_ack",
    "echo_back",
    "end_program",
    "end_program_now",
    "error_mark",
    "error_output",
    "inputs",
    "inputs_with_inp",
    "load_settings",
    "mode",
    "next_step",
    "outputs",
    "outputs_with_clr",
    "pause_program",
    "program_autostart",
    "program_buffer",
    "program_counter",
    "program_state",
    "program_text",
    "resume_program",
    "run_program",
    "select_motor",
    "selected_motor",
    "sensor_logic",
    "sensors",
    "set_baud_rate",
    "set_checksum",
    "set_cr_after_ack",
    "set_echo_back",
    "set_error_mark",
    "set_mode",
    "set_program_autostart",
    "status",
    "upload_program",
    "version",
]


def status() -> Command:
    """``""``: the status flags (reading clears bits 1-3, §10 "")."""
    return build('""')


def condition() -> Command:
    """``9``: every condition flag, the mode and the selected motor (form I clears, §10 9)."""
    return build("9")


def condition_bit(bit: int) -> Command:
    """``9{bit}``: one condition bit 0-7 (4/5 give the mode, 7 the selected motor)."""
    return build("9{bit}", bit=bit)


def version() -> Command:
    """``V``: the program version of the controller."""
    return build("V")


def mode() -> Command:
    """``E``: the operating mode."""
    return build("E")


def set_mode(value: int) -> Command:
    """``E{mode}``: set the operating mode 0-2."""
    return build("E{mode}", mode=value)


def selected_motor() -> Command:
    """``F``: the selected motor."""
    return build("F")


def select_motor(motor: int) -> Command:
    """``F{mt}``: select the motor later commands act on."""
    return build("F{mt}", mt=motor)


def inputs() -> Command:
    """``C``: the 8 general inputs."""
    return build("C")


def inputs_with_inp() -> Command:
    """``CA``: INP1/INP2 and the general inputs."""
    return build("CA")


def outputs() -> Command:
    """``CO``: the 8 general outputs."""
    return build("CO")


def outputs_with_clr() -> Command:
    """``COA``: CLR1/CLR2 and the general outputs."""
    return build("COA")


def sensors(motor: int | None = None) -> Command:
    """``CL`` (selected or moving motor) or ``CLM{mt}`` (motor MT): the sensor inputs."""
    return build("CL") if motor is None else build("CLM{mt}", mt=motor)


def sensor_logic() -> Command:
    """``EA``: the A/B contact logic of the selected motor's sensors."""
    return build("EA")


def error_output() -> Command:
    """``K``: the error-output setting."""
    return build("K")


def echo_back() -> Command:
    """``EE``: whether echo back is on."""
    return build("EE")


def set_echo_back(on: bool) -> Command:
    """``EE1`` / ``EE0``: switches framing."""
    return on_off("EE", on)


def cr_after_ack() -> Command:
    """``EL``: whether '>' is followed by CR."""
    return build("EL")


def set_cr_after_ack(on: bool) -> Command:
    """``EL1`` / ``EL0``: switches framing."""
    return on_off("EL", on)


def error_mark() -> Command:
    """``ER``: whether a command error is answered '>@'."""
    return build("ER")


def set_error_mark(on: bool) -> Command:
    """``ER1`` / ``ER0``: switches framing."""
    return on_off("ER", on)


def checksum() -> Command:
    """``SUM``: whether frames carry a checksum."""
    return build("SUM")


def set_checksum(on: bool) -> Command:
    """``SUM1`` / ``SUM0``: switches framing."""
    return on_off("SUM", on)


def baud_rate() -> Command:
    """``ES``: the baud rate code."""
    return build("ES")


def set_baud_rate(code: BaudCode) -> Command:
    """``ES{bp}``: set the baud rate and write it to the EEPROM."""
    return build("ES{bp}", bp=code)


def load_settings() -> Command:
    """``DL``: reload the DW settings from the EEPROM."""
    return build("DL")


def upload_program() -> Command:
    """``I``: open program reception (the program text follows, ended by CR)."""
    return build("I")


def program_text() -> Command:
    """``IR``: the program text in RAM."""
    return build("IR")


def run_program(label: str | None = None) -> Command:
    """``G`` (from the start) or ``G{lb}`` (from a label).

    Built from the model: the text ``"G" + "S"`` would read as ``GS`` (pause).
    """
    return build("G") if label is None else build("G{lb}", lb=label)


def program_state() -> Command:
    """``GSS``: running, ended, paused or ended by an error."""
    return build("GSS")


def next_step() -> Command:
    """``GN``: the position of the next statement."""
    return build("GN")


def program_buffer(buffer: ProgramBuffer) -> Command:
    """``GR{bf}``: one data buffer byte."""
    return build("GR{bf}", bf=buffer)


def program_counter(counter: int) -> Command:
    """``GR{ct}``: counter 1 or 2."""
    return build("GR{ct}", ct=counter)


def program_autostart() -> Command:
    """``GA``: whether the program starts at power-on."""
    return build("GA")


def end_program() -> Command:
    """``GE``: end the running program (its motion goes on)."""
    return build("GE")


def end_program_now() -> Command:
    """``GES``: end the running program and stop its motion."""
    return build("GES")


def pause_program() -> Command:
    """``GS``: pause the running program."""
    return build("GS")


def resume_program() -> Command:
    """``GC``: resume a program paused with ``GS``."""
    return build("GC")


def set_program_autostart(on: bool) -> Command:
    """``GAS`` (run the program at power-on) or ``GAR``; written to the EEPROM at once."""
    return build("GAS" if on else "GAR")
