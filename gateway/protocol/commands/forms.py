"""The catalog's forms the gateway asks about by identity: ``command.form is SELECT_MOTOR``.

A form is one object of the catalog, so comparing it by identity names what is meant and
cannot be fooled by how its text happens to be written.
"""

from __future__ import annotations

from collections.abc import Mapping

from gateway.protocol.command_text import REGISTRY
from gateway.protocol.commands.base import SpeedName
from gateway.protocol.spec import Form

__all__ = [
    "CLEARS_ERRORS",
    "CONDITION",
    "CONDITION_BIT",
    "ERASE_EEPROM",
    "ERROR_OUTPUT_BITS",
    "ERROR_OUTPUT_MASK",
    "LOAD_SETTINGS",
    "MODE",
    "MOVES_BY_POSITION_DATA",
    "MOVES_BY_TABLE_ENTRY",
    "MOVES_TO_ORIGIN",
    "MOVES_TO_POSITION_DATA",
    "MOVES_TO_TABLE_ENTRY",
    "ONE_PULSE_STEPS",
    "OPEN_PROGRAM",
    "ORIGIN_SEARCHES",
    "POSITION_FORMAT",
    "PROGRAM_ENDS",
    "PROGRAM_STARTS",
    "SELECTED_MOTOR",
    "SELECT_MOTOR",
    "SET_BAUD_RATE",
    "SET_MODE",
    "SET_SIGNED_POSITIONS",
    "SET_UNSIGNED_POSITIONS",
    "SPEED_STEPS",
    "STATUS",
]

#: ``""``: status flags.
STATUS: Form = REGISTRY.form('""')
#: ``9``: all condition flags.
CONDITION: Form = REGISTRY.form("9")
#: ``9{bit}``: one condition bit.
CONDITION_BIT: Form = REGISTRY.form("9{bit}")
#: ``F{mt}``: select a motor.
SELECT_MOTOR: Form = REGISTRY.form("F{mt}")
#: ``F``: which motor is selected.
SELECTED_MOTOR: Form = REGISTRY.form("F")
#: ``E{mode}``: set the operating mode.
SET_MODE: Form = REGISTRY.form("E{mode}")
#: ``E``: the operating mode.
MODE: Form = REGISTRY.form("E")
#: ``EP``: the position management (0 unsigned, 1 signed).
POSITION_FORMAT: Form = REGISTRY.form("EP")
#: ``DL``: every DW setting reloaded from the EEPROM.
LOAD_SETTINGS: Form = REGISTRY.form("DL")
#: ``EE///``: erase the EEPROM (silent for up to 20 s).
ERASE_EEPROM: Form = REGISTRY.form("EE///")
#: ``I``: open program reception.
OPEN_PROGRAM: Form = REGISTRY.form("I")
#: ``K{dt},{du}{dl}``: error output on a mask of output bits.
ERROR_OUTPUT_MASK: Form = REGISTRY.form("K{dt},{du}{dl}")
#: ``K{dt},{bt}``: error output on one output bit.
ERROR_OUTPUT_BITS: Form = REGISTRY.form("K{dt},{bt}")
#: ``G``, ``G{lb}``, ``GC``: a user program runs (and may print) after these.
PROGRAM_STARTS: frozenset[Form] = frozenset(REGISTRY.form(k) for k in ("G", "G{lb}", "GC"))
#: ``GE``, ``GES``: the user program has ended after these.
PROGRAM_ENDS: frozenset[Form] = frozenset(REGISTRY.form(k) for k in ("GE", "GES"))
#: The increment and decrement forms of a speed (§10 OHI/OHD, OLI/OLD, OSI/OSD): not
#: idempotent, so a lost reply is settled by reading the speed back.
SPEED_STEPS: Mapping[SpeedName, frozenset[Form]] = {
    name: frozenset((REGISTRY.form(f"{name}I{{id}}"), REGISTRY.form(f"{name}D{{dd}}")))
    for name in ("OH", "OL", "OS")
}
#: ``EP1`` / ``EP0``: signed or unsigned position management.
SET_SIGNED_POSITIONS: Form = REGISTRY.form("EP1")
SET_UNSIGNED_POSITIONS: Form = REGISTRY.form("EP0")
#: ``K{dt},{du}{dl}``, ``K{dt},{bt}``, ``KC``: they clear the limit and EMS bits of ``""``
#: as a side effect, without reporting them (§10 K forms I, II, IV).
CLEARS_ERRORS: frozenset[Form] = frozenset(
    REGISTRY.form(k) for k in ("K{dt},{du}{dl}", "K{dt},{bt}", "KC")
)

#: ``ES{bp}``: set the baud rate (written to the EEPROM at once).
SET_BAUD_RATE: Form = REGISTRY.form("ES{bp}")

# The motion forms whose end the soft limits work out before sending (§10 0-5, 7*, 8*, B).
#: ``3`` / ``3{mt}``: to the position data of ``2``.
MOVES_TO_POSITION_DATA: frozenset[Form] = frozenset(REGISTRY.form(k) for k in ("3", "3{mt}"))
#: ``4`` / ``5`` (and their ``{mt}`` forms): by the count of ``2``, CW (+1) or CCW (-1).
MOVES_BY_POSITION_DATA: Mapping[Form, int] = {
    REGISTRY.form(k): sign for k, sign in (("4", 1), ("4{mt}", 1), ("5", -1), ("5{mt}", -1))
}
#: ``B{pn}`` / ``B{pn}{mt}``: to entry ``pn`` of the position table.
MOVES_TO_TABLE_ENTRY: frozenset[Form] = frozenset(REGISTRY.form(k) for k in ("B{pn}", "B{pn}{mt}"))
#: ``B{pn}{dir}`` / ``B{pn}{mt}{dir}``: by the value of entry ``pn``, in direction ``dir``.
MOVES_BY_TABLE_ENTRY: frozenset[Form] = frozenset(
    REGISTRY.form(k) for k in ("B{pn}{dir}", "B{pn}{mt}{dir}")
)
#: ``1`` / ``1{mt}``: to position 0.
MOVES_TO_ORIGIN: frozenset[Form] = frozenset(REGISTRY.form(k) for k in ("1", "1{mt}"))
#: ``7*`` / ``8*``: one pulse CW (+1) or CCW (-1).
ONE_PULSE_STEPS: Mapping[Form, int] = {REGISTRY.form("7*"): 1, REGISTRY.form("8*"): -1}
#: ``0``, ``0A``, ``0H``, ``0R``, ``0Z``, ``0Q``: origin searches (where they end is the
#: machine's, not a count).
ORIGIN_SEARCHES: frozenset[Form] = frozenset(
    REGISTRY.form(k) for k in ("0", "0A", "0H", "0R", "0Z", "0Q")
)
