"""Moves, position data and table, jogs, stops, condition flags (§10 1 ... 9, A, B, H ... SS).

Facts from the RC-233 manual, chapter 10; see docs/manual-notes.md for the choices made where
the manual is ambiguous.
"""

from __future__ import annotations

from gateway.protocol.catalog.position_table import CMD_A, CMD_B, CMD_BPM
from gateway.protocol.params import Dec, IntChoice, Position
from gateway.protocol.spec import CommandSpec, Effect, Persist, ReplyFormat, Scope, form

ACK = ReplyFormat.ACK
CONDITION = ReplyFormat.CONDITION
CONDITION_BIT = ReplyFormat.CONDITION_BIT
DEC5 = ReplyFormat.DEC5
DIGIT = ReplyFormat.DIGIT
POSITION = ReplyFormat.POSITION
SPEED_POINT = ReplyFormat.SPEED_POINT
MOTION = Effect.MOTION
QUERY = Effect.QUERY
SETTING = Effect.SETTING
STOP = Effect.STOP

CMD_1 = CommandSpec(
    mnemonic="1",
    title="Electrical origin return (move to position 0 at High speed)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form("1", ACK, MOTION, "move the selected motor to position 0"),
        form(
            "1{mt}",
            ACK,
            MOTION,
            "select motor MT and move it to position 0",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
    ),
)

CMD_2 = CommandSpec(
    mnemonic="2",
    title="Position data for commands 3, 4, 5",
    section="10",
    scope=Scope.SHARED,
    persisted_by=Persist.DW,
    default="0",
    forms=(
        form(
            "2{pp}", ACK, SETTING, "set the position pulse count pp used by 3, 4, 5", Position("pp")
        ),
        # △: the device takes it while moving but stores the start position of the move
        # (§10 2 注意点); the gateway does not send it while moving.
        form(
            "2",
            ACK,
            SETTING,
            "store the current position as the position data",
            while_moving=False,
        ),
        form("2D", POSITION, QUERY, "query the position data"),
    ),
)

CMD_3 = CommandSpec(
    mnemonic="3",
    title="Absolute move to the '2' position (High speed)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form("3", ACK, MOTION, "move the selected motor to the position set with command 2"),
        form(
            "3{mt}",
            ACK,
            MOTION,
            "select motor MT and move it to the position set with command 2",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
    ),
)

CMD_4 = CommandSpec(
    mnemonic="4",
    title="Incremental move CW by the '2' pulse count (High speed)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form("4", ACK, MOTION, "move the selected motor CW by the command-2 pulse count"),
        form(
            "4{mt}",
            ACK,
            MOTION,
            "select motor MT and move it CW by the command-2 pulse count",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
    ),
)

CMD_5 = CommandSpec(
    mnemonic="5",
    title="Incremental move CCW by the '2' pulse count (High speed)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form("5", ACK, MOTION, "move the selected motor CCW by the command-2 pulse count"),
        form(
            "5{mt}",
            ACK,
            MOTION,
            "select motor MT and move it CCW by the command-2 pulse count",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
    ),
)

CMD_6 = CommandSpec(
    mnemonic="6",
    title="Current position query",
    section="10",
    scope=Scope.PER_MOTOR,
    forms=(
        form(
            "6",
            POSITION,
            QUERY,
            "query the current position of the selected motor",
            reads_position=True,
        ),
        form(
            "6{mt}",
            POSITION,
            QUERY,
            "query the current position of motor MT",
            IntChoice("mt", values=(1, 2)),
            reads_position=True,
        ),
    ),
)

CMD_7 = CommandSpec(
    mnemonic="7",
    title="Continuous CW rotation at Low speed",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form("7", ACK, MOTION, "rotate the selected motor CW at Low speed"),
        form(
            "7{mt}",
            ACK,
            MOTION,
            "select motor MT and rotate it CW at Low speed",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
    ),
)

CMD_7STAR = CommandSpec(
    mnemonic="7*",
    title="Single pulse CW",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(form("7*", ACK, MOTION, "move the selected motor 1 pulse CW"),),
)

CMD_8 = CommandSpec(
    mnemonic="8",
    title="Continuous CCW rotation at Low speed",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form("8", ACK, MOTION, "rotate the selected motor CCW at Low speed"),
        form(
            "8{mt}",
            ACK,
            MOTION,
            "select motor MT and rotate it CCW at Low speed",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
    ),
)

CMD_8STAR = CommandSpec(
    mnemonic="8*",
    title="Single pulse CCW",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(form("8*", ACK, MOTION, "move the selected motor 1 pulse CCW"),),
)

CMD_9 = CommandSpec(
    mnemonic="9",
    title="Condition flags query",
    section="10",
    scope=Scope.CONTROLLER,
    forms=(
        form("9", CONDITION, QUERY, "query all condition flags", clears_on_read=True),
        form(
            "9{bit}",
            CONDITION_BIT,
            QUERY,
            "query one condition bit",
            Dec("bit", lo=0, hi=7, digits=1),
        ),
    ),
)

CMD_H = CommandSpec(
    mnemonic="H",
    title="Switch jog to High speed",
    section="10",
    scope=Scope.PER_MOTOR,
    forms=(form("H", ACK, SETTING, "raise a 7/8 jog to High speed"),),
)

CMD_L = CommandSpec(
    mnemonic="L",
    title="Switch jog to Low speed",
    section="10",
    scope=Scope.PER_MOTOR,
    forms=(form("L", ACK, SETTING, "lower a 7/8 jog to Low speed"),),
)

CMD_N = CommandSpec(
    mnemonic="N",
    title="Automatic speed change during a move (NS/NC/NR)",
    section="10",
    scope=Scope.SHARED,
    while_moving=False,
    default="NS off; every point 0,0",
    forms=(
        form(
            "N{pn}{sp},{pj}",
            ACK,
            SETTING,
            "set speed-change point PN",
            Dec("pn", lo=1, hi=5, digits=1),
            Dec("sp", lo=0, hi=16383, digits=5),
            Dec("pj", lo=0, hi=16777215, digits=8),
        ),
        form("NS", ACK, SETTING, "(NS) arm the speed-change function for the next move"),
        form("NC", ACK, SETTING, "(NC) clear all point data"),
        form("NR", ACK, SETTING, "(NR) cancel NS"),
        form("N", DIGIT, QUERY, "query whether NS is armed"),
        form("N{pn}", SPEED_POINT, QUERY, "query point PN", Dec("pn", lo=1, hi=5, digits=1)),
    ),
)

CMD_R = CommandSpec(
    mnemonic="R",
    title="Set current position (origin reset / preset)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form("R", ACK, SETTING, "make the current position the origin"),
        form("R{pp}", ACK, SETTING, "set the current position to a value", Position("pp")),
    ),
)

CMD_S = CommandSpec(
    mnemonic="S",
    title="Stop immediately",
    section="10",
    scope=Scope.PER_MOTOR,
    forms=(form("S", ACK, STOP, "stop the motor at once", is_stop=True),),
)

CMD_SS = CommandSpec(
    mnemonic="SS",
    title="Slow stop (decelerate to Low speed, then stop)",
    section="10",
    scope=Scope.PER_MOTOR,
    forms=(form("SS", ACK, STOP, "decelerate and stop", is_stop=True),),
)


COMMANDS: tuple[CommandSpec, ...] = (
    CMD_1,
    CMD_2,
    CMD_3,
    CMD_4,
    CMD_5,
    CMD_6,
    CMD_7,
    CMD_7STAR,
    CMD_8,
    CMD_8STAR,
    CMD_9,
    CMD_A,
    CMD_B,
    CMD_BPM,
    CMD_H,
    CMD_L,
    CMD_N,
    CMD_R,
    CMD_S,
    CMD_SS,
)
