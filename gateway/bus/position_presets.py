"""Commands that change a position counter without motion, and the position reads that follow.

``R`` and ``R{pp}`` set the selected motor's current position (§10 R); ``E{mode}`` changes the
operating mode, and with it what the counter counts (§10 E: mode 1 counts the encoder); ``DL``
reloads the settings from the EEPROM (§10 DL), ``EP0``/``EP1`` how positions are told (§10 EP).
After any of them the cached position is not the device's any more: the state cache marks it
stale the moment the command is answered (``readings``), and the transaction reads it back
before it ends (``TransactionRunner``), so no client sees an old position as fresh.
"""

from __future__ import annotations

from gateway.protocol import commands
from gateway.protocol.command_text import REGISTRY
from gateway.protocol.models import Command
from gateway.protocol.spec import Form

__all__ = ["PRESETS_BOTH", "PRESETS_ONE", "presets_positions", "read_backs"]

#: The selected motor's position is set (§10 R form I and II).
PRESETS_ONE: frozenset[Form] = frozenset(REGISTRY.form(k) for k in ("R", "R{pp}"))
#: Both motors' positions may read otherwise after them (§10 E, DL, EP).
PRESETS_BOTH: frozenset[Form] = frozenset(
    {
        commands.SET_MODE,
        commands.LOAD_SETTINGS,
        commands.SET_SIGNED_POSITIONS,
        commands.SET_UNSIGNED_POSITIONS,
    }
)


def presets_positions(command: Command) -> bool:
    """Whether ``command`` may change a position counter without motion."""
    return command.form in PRESETS_ONE or command.form in PRESETS_BOTH


def read_backs(command: Command, motor: int | None) -> tuple[Command, ...]:
    """The position reads that tell what ``command`` left (``motor``: the one it acted on)."""
    if command.form in PRESETS_ONE and motor is not None:
        return (commands.position(motor),)
    return (commands.position(1), commands.position(2))
