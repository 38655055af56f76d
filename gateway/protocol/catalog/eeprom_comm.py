"""EEPROM load/save/erase and the framing modifiers EE, EL, ER, SUM, ES, plus V (§10).

Facts from the RC-233 manual, chapter 10; see docs/manual-notes.md for the choices made where
the manual is ambiguous.
"""

from __future__ import annotations

from gateway.protocol.params import IntChoice
from gateway.protocol.spec import CommandSpec, Effect, Persist, ReplyFormat, Scope, form

ACK = ReplyFormat.ACK
ACK_THEN_DONE = ReplyFormat.ACK_THEN_DONE
DIGIT = ReplyFormat.DIGIT
VERSION = ReplyFormat.VERSION
ACTION = Effect.ACTION
QUERY = Effect.QUERY
SETTING = Effect.SETTING

#: A framing change alters how the next exchange is written or answered, so a blind resend
#: after a lost reply is sent or read in the wrong framing (§10 EE, EL, ER, SUM): the
#: scheduler reads the framing back instead of resending.
FRAMING_CHANGE = False

CMD_AL = CommandSpec(
    mnemonic="AL",
    title="Load position table from EEPROM to RAM",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    while_program=False,
    forms=(form("AL", ACK, SETTING, "copy the A data written with AW from EEPROM to RAM"),),
)

CMD_AW = CommandSpec(
    mnemonic="AW",
    title="Write position table to EEPROM",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    user_program=False,
    persisted_by=Persist.AW,
    while_program=False,
    forms=(form("AW", ACK_THEN_DONE, ACTION, "write the A data (RAM) to EEPROM"),),
)

CMD_DL = CommandSpec(
    mnemonic="DL",
    title="Load DW settings from EEPROM to RAM",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    while_program=False,
    forms=(form("DL", ACK, SETTING, "copy the data written with DW from EEPROM to RAM"),),
)

CMD_DW = CommandSpec(
    mnemonic="DW",
    title="Write settings to EEPROM",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    user_program=False,
    persisted_by=Persist.DW,
    while_program=False,
    forms=(
        form(
            "DW",
            ACK_THEN_DONE,
            ACTION,
            "write the current settings of the DW target commands to EEPROM",
        ),
    ),
)

CMD_EE = CommandSpec(
    mnemonic="EE",
    title="Echo-back function",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    persisted_by=Persist.DW,
    default="0",
    forms=(
        form(
            "EE1",
            ACK,
            SETTING,
            "enable echo back",
            idempotent_override=FRAMING_CHANGE,
            switches_framing=True,
        ),
        form(
            "EE0",
            ACK,
            SETTING,
            "disable echo back (default)",
            idempotent_override=FRAMING_CHANGE,
            switches_framing=True,
        ),
        form("EE", DIGIT, QUERY, "query whether echo back is enabled"),
    ),
)

CMD_EE_ERASE = CommandSpec(
    mnemonic="EE///",
    title="Erase all EEPROM data",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    user_program=False,
    forms=(form("EE///", ACK_THEN_DONE, ACTION, "erase everything written to EEPROM"),),
)

CMD_EL = CommandSpec(
    mnemonic="EL",
    title="Append CR to the '>' reply",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    persisted_by=Persist.DW,
    default="0",
    forms=(
        form(
            "EL1",
            ACK,
            SETTING,
            "enable: general-command reply becomes '>' CR",
            idempotent_override=FRAMING_CHANGE,
            switches_framing=True,
        ),
        form(
            "EL0",
            ACK,
            SETTING,
            "disable (default)",
            idempotent_override=FRAMING_CHANGE,
            switches_framing=True,
        ),
        form("EL", DIGIT, QUERY, "query whether the function is enabled"),
    ),
)

CMD_ER = CommandSpec(
    mnemonic="ER",
    title="Command-error display function ('>@' reply)",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    persisted_by=Persist.DW,
    default="0",
    forms=(
        form(
            "ER1",
            ACK,
            SETTING,
            "enable: a command with a command error is answered '>@'",
            idempotent_override=FRAMING_CHANGE,
            switches_framing=True,
        ),
        form(
            "ER0",
            ACK,
            SETTING,
            "disable (default)",
            idempotent_override=FRAMING_CHANGE,
            switches_framing=True,
        ),
        form("ER", DIGIT, QUERY, "query whether the function is enabled"),
    ),
)

CMD_ES = CommandSpec(
    mnemonic="ES",
    title="Baud rate (set and store in EEPROM)",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    persisted_by=Persist.ES,
    default="0",
    forms=(
        form(
            "ES{bp}",
            ACK,
            ACTION,
            "set the communication baud rate; the value is written to EEPROM at the same time",
            IntChoice("bp", values=(0, 1, 2)),
        ),
        form("ES", DIGIT, QUERY, "query the current baud rate"),
    ),
)

CMD_SUM = CommandSpec(
    mnemonic="SUM",
    title="Checksum function",
    section="10",
    scope=Scope.CONTROLLER,
    persisted_by=Persist.DW,
    default="0",
    forms=(
        form(
            "SUM1",
            ACK,
            SETTING,
            "enable the checksum",
            idempotent_override=FRAMING_CHANGE,
            switches_framing=True,
        ),
        form(
            "SUM0",
            ACK,
            SETTING,
            "disable the checksum (default)",
            idempotent_override=FRAMING_CHANGE,
            switches_framing=True,
        ),
        form("SUM", DIGIT, QUERY, "query"),
    ),
)

CMD_V = CommandSpec(
    mnemonic="V",
    title="ROM version query",
    section="10",
    scope=Scope.CONTROLLER,
    forms=(form("V", VERSION, QUERY, "query the program version of the external ROM"),),
)


COMMANDS: tuple[CommandSpec, ...] = (
    CMD_AL,
    CMD_AW,
    CMD_DL,
    CMD_DW,
    CMD_EE,
    CMD_EE_ERASE,
    CMD_EL,
    CMD_ER,
    CMD_ES,
    CMD_SUM,
    CMD_V,
)
