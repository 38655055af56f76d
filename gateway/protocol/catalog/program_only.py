"""User-program-only commands of chapter 12 (/AND ... /?), never sent by the host.

Facts from the RC-233 manual, chapter 12; see docs/manual-notes.md for the choices made where
the manual is ambiguous.
"""

from __future__ import annotations

from gateway.protocol.catalog.program_flow import (
    CMD_P_,
    CMD_P__,
    CMD_P_END,
    CMD_P_G,
    CMD_P_J,
    CMD_P_JB,
    CMD_P_JC,
    CMD_P_JE,
    CMD_P_JM,
    CMD_P_JO,
    CMD_P_JP,
    CMD_P_JR,
    CMD_P_JT,
    CMD_P_SC,
    CMD_P_SR,
)
from gateway.protocol.params import (
    CharChoice,
    Dec,
    HexDigit,
    IntChoice,
)
from gateway.protocol.spec import CommandSpec, Effect, ReplyFormat, Scope, form
from gateway.protocol.text_params import Text

NONE = ReplyFormat.NONE
ACTION = Effect.ACTION

CMD_P_AND = CommandSpec(
    mnemonic="/AND",
    title="Data buffer AND",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "AND{bf}{du}{dl}",
            NONE,
            ACTION,
            "buffer AND immediate byte",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            HexDigit("du", lo=0, hi=15),
            HexDigit("dl", lo=0, hi=15),
        ),
        form(
            "AND{bf}R{b2}",
            NONE,
            ACTION,
            "buffer AND buffer",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            CharChoice("b2", values=("A", "B", "C", "D", "E", "F")),
        ),
    ),
)

CMD_P_BS = CommandSpec(
    mnemonic="/BS",
    title="Data buffer bit set/clear",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "BS{bf}{bt}{dt}",
            NONE,
            ACTION,
            "write one bit of a buffer",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            Dec("bt", lo=0, hi=7, digits=1),
            IntChoice("dt", values=(0, 1)),
        ),
    ),
)

CMD_P_CC = CommandSpec(
    mnemonic="/CC",
    notes=("sends >$B# CT nnnnn CR (counter and 5 digits) to the host (§12 /CC)",),
    title="Send counter value to host",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "CC{ct}",
            NONE,
            ACTION,
            "transfer a counter's count to the PC",
            IntChoice("ct", values=(1, 2)),
        ),
    ),
)

CMD_P_CD = CommandSpec(
    mnemonic="/CD",
    title="Counter decrement",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("CD{ct}", NONE, ACTION, "decrement a counter", IntChoice("ct", values=(1, 2))),),
)

CMD_P_CO = CommandSpec(
    mnemonic="/CO",
    notes=("sends > text CR to the host (§12 /CO example: >123ABC*+-% CR)",),
    title="Send a string to host",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("CO{dt}", NONE, ACTION, "transfer a string to the PC", Text("dt", max_len=20)),),
)

CMD_P_CS = CommandSpec(
    mnemonic="/CS",
    title="Counter set",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "CS{ct},{cn}",
            NONE,
            ACTION,
            "set a counter",
            IntChoice("ct", values=(1, 2)),
            Dec("cn", lo=0, hi=65535, digits=5),
        ),
    ),
)

CMD_P_CU = CommandSpec(
    mnemonic="/CU",
    title="Counter increment",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("CU{ct}", NONE, ACTION, "increment a counter", IntChoice("ct", values=(1, 2))),),
)

CMD_P_EC = CommandSpec(
    mnemonic="/EC",
    title="Error clear",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form("EC", NONE, ACTION, "clear all error bits"),
        form("EC{bt}", NONE, ACTION, "clear one error bit", IntChoice("bt", values=(0, 1, 2, 6))),
    ),
)

CMD_P_I1 = CommandSpec(
    mnemonic="/I1",
    title="Read input port into buffer",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "I1{bf}",
            NONE,
            ACTION,
            "read the general input port",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
        ),
    ),
)

CMD_P_IL = CommandSpec(
    mnemonic="/IL",
    title="Read sensor inputs into buffer",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "IL{bf}",
            NONE,
            ACTION,
            "read ORG/limit sensor states",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
        ),
    ),
)

CMD_P_LD = CommandSpec(
    mnemonic="/LD",
    title="Data buffer load",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "LD{bf}{du}{dl}",
            NONE,
            ACTION,
            "load a byte into a buffer",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            HexDigit("du", lo=0, hi=15),
            HexDigit("dl", lo=0, hi=15),
        ),
        form(
            "LD{bf}R{b2}",
            NONE,
            ACTION,
            "copy a buffer",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            CharChoice("b2", values=("A", "B", "C", "D", "E", "F")),
        ),
    ),
)

CMD_P_O = CommandSpec(
    mnemonic="/O",
    notes=("with PT 3 sends the buffer DU DL to the host (§12 /O)",),
    title="Data buffer output (port or host)",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "O{pt}{bf}",
            NONE,
            ACTION,
            "output a buffer to the output port or to the PC",
            IntChoice("pt", values=(1, 3)),
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
        ),
    ),
)

CMD_P_OR = CommandSpec(
    mnemonic="/OR",
    title="Data buffer OR",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "OR{bf}{du}{dl}",
            NONE,
            ACTION,
            "buffer OR immediate byte",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            HexDigit("du", lo=0, hi=15),
            HexDigit("dl", lo=0, hi=15),
        ),
        form(
            "OR{bf}R{b2}",
            NONE,
            ACTION,
            "buffer OR buffer",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            CharChoice("b2", values=("A", "B", "C", "D", "E", "F")),
        ),
    ),
)

CMD_P_RR = CommandSpec(
    mnemonic="/RR",
    title="Data buffer rotate right",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "RR{bf}",
            NONE,
            ACTION,
            "rotate a buffer right",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
        ),
    ),
)

CMD_P_RL = CommandSpec(
    mnemonic="/RL",
    title="Data buffer rotate left",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "RL{bf}",
            NONE,
            ACTION,
            "rotate a buffer left",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
        ),
    ),
)

CMD_P_T = CommandSpec(
    mnemonic="/T",
    title="Timer wait",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "T{dt}",
            NONE,
            ACTION,
            "start the timer and wait for time-up",
            Dec("dt", lo=0, hi=32767, digits=5),
        ),
    ),
)

CMD_P_TB = CommandSpec(
    mnemonic="/TB",
    title="Timer start (for /JT)",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "TB{dt}",
            NONE,
            ACTION,
            "start the timer without waiting",
            Dec("dt", lo=0, hi=32767, digits=5),
        ),
    ),
)

CMD_P_TS = CommandSpec(
    mnemonic="/TS",
    title="Stop-wait time after each NULL wait",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "TS{dt}",
            NONE,
            ACTION,
            "set the extra wait after each '/ (NULL)'",
            Dec("dt", lo=0, hi=32767, digits=5),
        ),
    ),
)

CMD_P_WAW = CommandSpec(
    mnemonic="/WAW",
    title="Write position data to EEPROM and wait",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("WAW", NONE, ACTION, "execute AW and wait until writing has finished"),),
)

CMD_P_WDW = CommandSpec(
    mnemonic="/WDW",
    title="Write settings to EEPROM and wait",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("WDW", NONE, ACTION, "execute DW and wait until writing has finished"),),
)

COMMANDS: tuple[CommandSpec, ...] = (
    CMD_P_,
    CMD_P_AND,
    CMD_P_BS,
    CMD_P_CC,
    CMD_P_CD,
    CMD_P_CO,
    CMD_P_CS,
    CMD_P_CU,
    CMD_P_EC,
    CMD_P_END,
    CMD_P_G,
    CMD_P_I1,
    CMD_P_IL,
    CMD_P_J,
    CMD_P_JB,
    CMD_P_JC,
    CMD_P_JE,
    CMD_P_JM,
    CMD_P_JO,
    CMD_P_JP,
    CMD_P_JR,
    CMD_P_JT,
    CMD_P_LD,
    CMD_P_O,
    CMD_P_OR,
    CMD_P_RR,
    CMD_P_RL,
    CMD_P_SC,
    CMD_P_SR,
    CMD_P_T,
    CMD_P_TB,
    CMD_P_TS,
    CMD_P_WAW,
    CMD_P_WDW,
    CMD_P__,
)
