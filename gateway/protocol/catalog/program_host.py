"""Host commands that upload, store, run and inspect the user program (§10 G ... IW).

Facts from the RC-233 manual, chapter 10; see docs/manual-notes.md for the choices made where
the manual is ambiguous.
"""

from __future__ import annotations

from gateway.protocol.params import CharChoice, Dec, HexDigit, IntChoice
from gateway.protocol.spec import CommandSpec, Effect, Persist, ReplyFormat, Scope, form
from gateway.protocol.text_params import Label

ACK = ReplyFormat.ACK
BUFFER = ReplyFormat.BUFFER
ACK_THEN_DONE = ReplyFormat.ACK_THEN_DONE
DEC5 = ReplyFormat.DEC5
DIGIT = ReplyFormat.DIGIT
PROGRAM_STATE = ReplyFormat.PROGRAM_STATE
PROGRAM_TEXT = ReplyFormat.PROGRAM_TEXT
ACTION = Effect.ACTION
QUERY = Effect.QUERY
SETTING = Effect.SETTING
STOP = Effect.STOP

CMD_G = CommandSpec(
    mnemonic="G",
    title="Run user program",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    while_program=False,
    forms=(
        form("G", ACK, ACTION, "run the user program in RAM from its first command"),
        form("G{lb}", ACK, ACTION, "run the user program from a label", Label("lb", host=True)),
    ),
)

CMD_GA = CommandSpec(
    mnemonic="GA",
    title="User-program auto-start (GAS/GAR)",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    user_program=False,
    persisted_by=Persist.GA,
    default="0",
    forms=(
        form("GAS", ACK, ACTION, "enable auto-start (written to EEPROM at once)"),
        form("GAR", ACK, ACTION, "disable auto-start (written to EEPROM at once, default)"),
        form("GA", DIGIT, QUERY, "query auto-start"),
    ),
)

CMD_GC = CommandSpec(
    mnemonic="GC",
    title="Continue a paused user program",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(form("GC", ACK, ACTION, "resume a program paused with GS"),),
)

CMD_GE = CommandSpec(
    mnemonic="GE",
    title="End user program at an operation boundary",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(form("GE", ACK, STOP, "end the running program"),),
)

CMD_GES = CommandSpec(
    mnemonic="GES",
    title="End user program immediately (and stop the motor)",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(form("GES", ACK, STOP, "end the running program at once", is_stop=True),),
)

CMD_GN = CommandSpec(
    mnemonic="GN",
    title="Query user-program command position",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(form("GN", DEC5, QUERY, "query the position of the next command"),),
)

CMD_GR = CommandSpec(
    mnemonic="GR",
    title="Query data buffer or counter",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(
        form(
            "GR{bf}",
            BUFFER,
            QUERY,
            "query a data buffer",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
        ),
        form("GR{ct}", DEC5, QUERY, "query a counter", IntChoice("ct", values=(1, 2))),
    ),
)

CMD_GRT = CommandSpec(
    mnemonic="GRT",
    title="Query internal timer count",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(form("GRT", DEC5, QUERY, "query the remaining time of the internal timer"),),
)

CMD_GS = CommandSpec(
    mnemonic="GS",
    title="Pause user program",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(form("GS", ACK, STOP, "pause the running program"),),
)

CMD_GSS = CommandSpec(
    mnemonic="GSS",
    title="Query user-program state",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(
        form(
            "GSS",
            PROGRAM_STATE,
            QUERY,
            "query whether the program runs, ended, is paused or ended by error",
            clears_on_read=True,
        ),
    ),
)

CMD_GW = CommandSpec(
    mnemonic="GW",
    title="Write data buffer or counter",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(
        form(
            "GW{bf}{du}{dl}",
            ACK,
            SETTING,
            "set a data buffer",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            HexDigit("du", lo=0, hi=15),
            HexDigit("dl", lo=0, hi=15),
        ),
        form(
            "GW{ct}{dt}",
            ACK,
            SETTING,
            "set a counter",
            IntChoice("ct", values=(1, 2)),
            Dec("dt", lo=0, hi=65535, digits=5),
        ),
    ),
)

CMD_GWT = CommandSpec(
    mnemonic="GWT",
    title="Change the running timer value",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(
        form(
            "GWT{time}",
            ACK,
            ACTION,  # restarts the countdown from the new time (§10 GWT)
            "rewrite the time of the timer that is counting",
            Dec("time", lo=0, hi=32767, digits=5),
        ),
    ),
)

CMD_I = CommandSpec(
    mnemonic="I",
    title="Upload user program to RAM",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    persisted_by=Persist.IW,
    while_program=False,
    forms=(form("I", ACK, ACTION, "(manual ①) open program reception"),),
)

CMD_IL = CommandSpec(
    mnemonic="IL",
    title="Load user program from EEPROM into RAM",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    user_program=False,
    while_program=False,
    forms=(form("IL", ACK, SETTING, "copy the EEPROM program into RAM"),),
)

CMD_IR = CommandSpec(
    mnemonic="IR",
    title="Read back the RAM user program",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(form("IR", PROGRAM_TEXT, QUERY, "query the content of the RAM user program"),),
)

CMD_IW = CommandSpec(
    mnemonic="IW",
    title="Write user program to EEPROM",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    user_program=False,
    persisted_by=Persist.IW,
    while_program=False,
    forms=(form("IW", ACK_THEN_DONE, ACTION, "store the RAM program in EEPROM"),),
)


COMMANDS: tuple[CommandSpec, ...] = (
    CMD_G,
    CMD_GA,
    CMD_GC,
    CMD_GE,
    CMD_GES,
    CMD_GN,
    CMD_GR,
    CMD_GRT,
    CMD_GS,
    CMD_GSS,
    CMD_GW,
    CMD_GWT,
    CMD_I,
    CMD_IL,
    CMD_IR,
    CMD_IW,
)
