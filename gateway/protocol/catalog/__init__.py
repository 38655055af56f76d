"""The catalog: every command of chapters 10 and 12, in the manual's order.

One ``CommandSpec`` per mnemonic, grouped into modules by subject. ``ALL_COMMANDS`` is the
explicit tuple the registry is built from; nothing registers itself on import.
"""

from __future__ import annotations

from gateway.protocol.catalog import (
    eeprom_comm,
    io_sensors,
    motion,
    program_host,
    program_only,
    settings,
    status_homing,
)
from gateway.protocol.spec import CommandSpec

__all__ = ["ALL_COMMANDS", "HOST_COMMANDS", "PROGRAM_ONLY_COMMANDS"]

#: Host commands of chapter 10 (sent as '$' B# text CR), sorted as the manual's index.
HOST_COMMANDS: tuple[CommandSpec, ...] = tuple(
    sorted(
        (
            *status_homing.COMMANDS,
            *motion.COMMANDS,
            *io_sensors.COMMANDS,
            *settings.COMMANDS,
            *eeprom_comm.COMMANDS,
            *program_host.COMMANDS,
        ),
        key=lambda spec: (spec.mnemonic != "", spec.mnemonic),
    )
)

#: User-program-only commands of chapter 12 ('/AND' ... '/?').
PROGRAM_ONLY_COMMANDS: tuple[CommandSpec, ...] = program_only.COMMANDS

ALL_COMMANDS: tuple[CommandSpec, ...] = HOST_COMMANDS + PROGRAM_ONLY_COMMANDS
