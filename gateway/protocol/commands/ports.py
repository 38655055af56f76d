"""Constructors of the I/O port and sensor logic settings (§10 C, CO, D, DA, P, EA)."""

from __future__ import annotations

from gateway.protocol.commands.base import build
from gateway.protocol.models import Command

__all__ = [
    "input_bit",
    "output_bit",
    "pulse_output",
    "set_output_bit",
    "set_outputs",
    "set_sensor_logic",
]

#: The output "bits" 8 and 9 are CLR1 and CLR2, set with their own form (§10 D form III).
_CLR_BITS = (8, 9)


def input_bit(bit: int) -> Command:
    """``C{bit}``: one general input 0-7, or INP1 (8) / INP2 (9)."""
    return build("C{bit}", bit=bit)


def output_bit(bit: int) -> Command:
    """``CO{bit}``: one general output 0-7, or CLR1 (8) / CLR2 (9)."""
    return build("CO{bit}", bit=bit)


def set_outputs(value: int, clr: tuple[bool, bool] | None = None) -> Command:
    """``D{du}{dl}``: the 8 general outputs to the byte ``value``; with ``clr`` (CLR1, CLR2)
    also those, ``DA{dc}{du}{dl}`` (modes 0 and 1)."""
    du, dl = value >> 4, value & 0xF
    if clr is None:
        return build("D{du}{dl}", du=du, dl=dl)
    dc = int(clr[0]) | int(clr[1]) << 1  # DC bit 0 CLR1, bit 1 CLR2
    return build("DA{dc}{du}{dl}", dc=dc, du=du, dl=dl)


def set_output_bit(bit: int, on: bool) -> Command:
    """``D{bit}{value}B`` (a general output 0-7) or ``D{clr}{value}B`` (8 CLR1, 9 CLR2)."""
    if bit in _CLR_BITS:
        return build("D{clr}{value}B", clr=bit, value=int(on))
    return build("D{bit}{value}B", bit=bit, value=int(on))


def pulse_output(bit: int, time: int) -> Command:
    """``P{bt}{time}``: output ``bit`` ON for ``time`` x 100 ms (it uses the timer)."""
    return build("P{bt}{time}", bt=bit, time=time)


def set_sensor_logic(byte: int) -> Command:
    """``EA{du}{dl}``: the A/B contact logic of the selected motor's sensors, as the byte
    ``EA`` reads (the EMS bit is common to both motors)."""
    return build("EA{du}{dl}", du=byte >> 4, dl=byte & 0xF)
