"""Status query and origin searches (§10 "" and 0 ... 0Z).

Facts from the RC-233 manual, chapter 10; see docs/manual-notes.md for the choices made where
the manual is ambiguous.
"""

from __future__ import annotations

from gateway.protocol.params import Dec, IntChoice
from gateway.protocol.spec import CommandSpec, Effect, Persist, ReplyFormat, Scope, form

ACK = ReplyFormat.ACK
DEC5 = ReplyFormat.DEC5
DIGIT = ReplyFormat.DIGIT
STATUS = ReplyFormat.STATUS
MOTION = Effect.MOTION
QUERY = Effect.QUERY
SETTING = Effect.SETTING

CMD_STATUS = CommandSpec(
    mnemonic="",
    title="Status query (NULL command)",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(
        form(
            "",
            STATUS,
            QUERY,
            "query status flags: motor moving, limit error, emergency stop, command error",
            clears_on_read=True,
        ),
    ),
)

CMD_0 = CommandSpec(
    mnemonic="0",
    title="Mechanical origin search 1 (low speed, ORG sensor)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form("0", ACK, MOTION, "run origin search 1 on the currently selected motor"),
        form(
            "0{mt}",
            ACK,
            MOTION,
            "select motor MT and run origin search 1 on it",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
    ),
)

CMD_0A = CommandSpec(
    mnemonic="0A",
    title="High-speed origin search 2 (immediate stop at ORG)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form("0A", ACK, MOTION, "run high-speed origin search 2 on the currently selected motor"),
        form(
            "0A{mt}",
            ACK,
            MOTION,
            "select motor MT and run high-speed origin search 2",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
    ),
)

CMD_0B = CommandSpec(
    mnemonic="0B",
    title="Origin-search back-off multiplier (multiple of 0S)",
    section="10",
    scope=Scope.PER_MOTOR,
    persisted_by=Persist.DW,
    default="2",
    forms=(
        form(
            "0B{n}",
            ACK,
            SETTING,
            "set the multiplier applied to the 0S pulse count",
            Dec("n", lo=0, hi=5, digits=1),
        ),
        form("0B", DIGIT, QUERY, "query the multiplier of the selected motor"),
    ),
)

CMD_0H = CommandSpec(
    mnemonic="0H",
    title="High-speed origin search 1 (decelerate at ORG)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form("0H", ACK, MOTION, "run high-speed origin search 1 on the currently selected motor"),
        form(
            "0H{mt}",
            ACK,
            MOTION,
            "select motor MT and run high-speed origin search 1",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
    ),
)

CMD_0Q = CommandSpec(
    mnemonic="0Q",
    title="Step-out detection dog centring (sets origin)",
    section="10",
    scope=Scope.PER_MOTOR,
    modes=frozenset({0, 2}),
    persisted_by=Persist.DW,
    default="10",
    forms=(
        form(
            "0Q",
            ACK,
            MOTION,
            "centre the step-out sensor on the step-out dog; that point becomes the origin",
            while_moving=False,
        ),
        form(
            "0Q{pd}",
            ACK,
            SETTING,
            "set the pulses the step-out sensor must stay ON (anti-chatter guard for 0Q)",
            Dec("pd", lo=1, hi=65535, digits=5),
        ),
        form("0QD", DEC5, QUERY, "query the pd value set with form II"),
        form(
            "0QW",
            DEC5,
            QUERY,
            "query the sensor-ON width (pulses) actually counted during the last form-I centring",
        ),
    ),
)

CMD_0R = CommandSpec(
    mnemonic="0R",
    title="Mechanical origin search 2 (RC-204A compatible)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form("0R", ACK, MOTION, "run origin search 2 on the currently selected motor"),
        form(
            "0R{mt}",
            ACK,
            MOTION,
            "select motor MT and run origin search 2",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
    ),
)

CMD_0S = CommandSpec(
    mnemonic="0S",
    title="Origin-search offset pulses (travel after ORG ON)",
    section="10",
    scope=Scope.PER_MOTOR,
    persisted_by=Persist.DW,
    default="20",
    forms=(
        form(
            "0S{pd}",
            ACK,
            SETTING,
            "set the pulse count the origin searches travel after the ORG edge",
            Dec("pd", lo=1, hi=65535, digits=5),
        ),
        form("0S", DEC5, QUERY, "query the offset of the selected motor"),
    ),
)

CMD_0X = CommandSpec(
    mnemonic="0X",
    title="Mode-2 origin-search algorithm select (conventional / new)",
    section="10",
    scope=Scope.SHARED,
    modes=frozenset({2}),
    while_moving=False,
    persisted_by=Persist.DW,
    default="0",
    forms=(
        form("0X1", ACK, SETTING, "use the new algorithm for origin searches in mode 2"),
        form("0X0", ACK, SETTING, "use the conventional algorithm (default)"),
        form("0X", DIGIT, QUERY, "query the selected algorithm"),
    ),
)

CMD_0Z = CommandSpec(
    mnemonic="0Z",
    title="Origin search with encoder Z phase (EZ) and ORG",
    section="10",
    scope=Scope.SHARED,
    while_moving=False,
    persisted_by=Persist.DW,
    default="1",
    forms=(
        form(
            "0Z", ACK, MOTION, "run the Z-phase + ORG origin search on the currently selected motor"
        ),
        form(
            "0Z{n}",
            ACK,
            SETTING,
            "set at which Z-phase ON (counted after ORG ON) the origin is defined",
            Dec("n", lo=1, hi=9, digits=1),
        ),
        form("0ZD", DIGIT, QUERY, "query the Z count"),
    ),
)


COMMANDS: tuple[CommandSpec, ...] = (
    CMD_STATUS,
    CMD_0,
    CMD_0A,
    CMD_0B,
    CMD_0H,
    CMD_0Q,
    CMD_0R,
    CMD_0S,
    CMD_0X,
    CMD_0Z,
)
