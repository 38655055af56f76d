"""Inputs, outputs, sensors, sensor logic, error output, pulse output and the timer (§10 C ... T).

Facts from the RC-233 manual, chapter 10; see docs/manual-notes.md for the choices made where
the manual is ambiguous.
"""

from __future__ import annotations

from gateway.protocol.params import Dec, HexDigit, IntChoice
from gateway.protocol.spec import CommandSpec, Effect, Persist, ReplyFormat, Scope, form

ACK = ReplyFormat.ACK
INPUTS = ReplyFormat.INPUTS
INPUTS_INP = ReplyFormat.INPUTS_INP
SENSORS = ReplyFormat.SENSORS
OUTPUTS = ReplyFormat.OUTPUTS
OUTPUTS_CLR = ReplyFormat.OUTPUTS_CLR
CLR_STATE = ReplyFormat.CLR_STATE
SENSOR_LOGIC = ReplyFormat.SENSOR_LOGIC
ACK_THEN_TIMER = ReplyFormat.ACK_THEN_TIMER
DIGIT = ReplyFormat.DIGIT
ERROR_OUTPUT = ReplyFormat.ERROR_OUTPUT
ACTION = Effect.ACTION
QUERY = Effect.QUERY
SETTING = Effect.SETTING

CMD_C = CommandSpec(
    mnemonic="C",
    title="General input port (and INP1/INP2) query",
    section="10",
    scope=Scope.CONTROLLER,
    forms=(
        form("C", INPUTS, QUERY, "query all 8 general inputs"),
        form(
            "C{bit}",
            DIGIT,
            QUERY,
            "query one input bit (0-7 general inputs, 8 = INP1, 9 = INP2)",
            Dec("bit", lo=0, hi=9, digits=1),
        ),
        form(
            "CA",
            INPUTS_INP,
            QUERY,
            "query INP1/INP2 and all general inputs at once (not in mode 2)",
            modes=frozenset({0, 1}),
        ),
    ),
)

CMD_CI = CommandSpec(
    mnemonic="CI",
    title="INP (in-position) input query (mode 2)",
    section="10",
    scope=Scope.PER_MOTOR,
    modes=frozenset({2}),
    forms=(
        form("CI", DIGIT, QUERY, "query the INP signal of the selected motor"),
        form(
            "CI{mt}",
            DIGIT,
            QUERY,
            "query the INP signal of motor MT",
            IntChoice("mt", values=(1, 2)),
        ),
    ),
)

CMD_CL = CommandSpec(
    mnemonic="CL",
    title="Sensor input query (ORG, limits, EMS, step-out sensor)",
    section="10",
    scope=Scope.PER_MOTOR,
    forms=(
        form("CL", SENSORS, QUERY, "query all sensor inputs of the selected (or moving) motor"),
        form("CL{bit}", DIGIT, QUERY, "query one sensor bit", Dec("bit", lo=0, hi=7, digits=1)),
        form(
            "CLM{mt}",
            SENSORS,
            QUERY,
            "query all sensor inputs of motor MT (not while moving)",
            IntChoice("mt", values=(1, 2)),
            while_moving=False,
        ),
    ),
)

CMD_CO = CommandSpec(
    mnemonic="CO",
    title="General output port (and CLR1/CLR2) state query",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(
        form("CO", OUTPUTS, QUERY, "query all 8 general outputs"),
        form(
            "COA",
            OUTPUTS_CLR,
            QUERY,
            "query CLR1/CLR2 outputs and all general outputs at once (not in mode 2)",
            modes=frozenset({0, 1}),
        ),
        form(
            "CO{bit}",
            DIGIT,
            QUERY,
            "query one output bit; §4-5 names 'CO8' (CLR1) and 'CO9' (CLR2)",
            Dec("bit", lo=0, hi=9, digits=1),
        ),
    ),
)

CMD_D = CommandSpec(
    mnemonic="D",
    title="General output port / CLR1-CLR2 output set",
    section="10",
    scope=Scope.CONTROLLER,
    default="00",
    forms=(
        form(
            "D{du}{dl}",
            ACK,
            SETTING,
            "set all 8 general outputs at once",
            HexDigit("du", lo=0, hi=15),
            HexDigit("dl", lo=0, hi=15),
        ),
        form(
            "D{bit}{value}B",
            ACK,
            SETTING,
            "set one general output bit 0-7",
            IntChoice("bit", values=(0, 1, 2, 3, 4, 5, 6, 7)),
            IntChoice("value", values=(0, 1)),
        ),
        form(
            "D{clr}{value}B",
            ACK,
            SETTING,
            "set CLR1 (8) or CLR2 (9) as a general output (not in mode 2: use DS there)",
            IntChoice("clr", values=(8, 9)),
            IntChoice("value", values=(0, 1)),
            modes=frozenset({0, 1}),
        ),
        form(
            "DA{dc}{du}{dl}",
            ACK,
            SETTING,
            "set CLR1/CLR2 and all 8 general outputs at once (not in mode 2)",
            HexDigit("dc", lo=0, hi=3),
            HexDigit("du", lo=0, hi=15),
            HexDigit("dl", lo=0, hi=15),
            modes=frozenset({0, 1}),
        ),
    ),
)

CMD_DS = CommandSpec(
    mnemonic="DS",
    title="CLR (deviation counter clear) output force / query (mode 2)",
    section="10",
    scope=Scope.CONTROLLER,
    modes=frozenset({2}),
    forms=(
        form(
            "DS{c2}{c1}",
            ACK,
            SETTING,
            "force CLR2 and CLR1 ON/OFF",
            Dec("c2", lo=0, hi=1, digits=1),
            Dec("c1", lo=0, hi=1, digits=1),
        ),
        form("DSR", ACK, SETTING, "turn CLR1 and CLR2 OFF"),
        form("DS", CLR_STATE, QUERY, "query the CLR outputs"),
    ),
)

CMD_EA = CommandSpec(
    mnemonic="EA",
    notes=(
        "bit 4 (EMS) and bit 5 (INP) are common to both motors; EAH/EAL set both motors (§10 EA)",
    ),
    title="Sensor input logic (A / B contact)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    persisted_by=Persist.DW,
    default="00",
    forms=(
        form(
            "EA{du}{dl}",
            ACK,
            SETTING,
            "set the input logic of all sensors of the selected motor at once",
            HexDigit("du", lo=0, hi=15),
            HexDigit("dl", lo=0, hi=15),
        ),
        form(
            "EA{bit}{value}B",
            ACK,
            SETTING,
            "set the input logic of one sensor of the selected motor",
            Dec("bit", lo=0, hi=7, digits=1),
            Dec("value", lo=0, hi=1, digits=1),
        ),
        form("EAH", ACK, SETTING, "set both motors to the logic of RORZE controller RC-231HA"),
        form("EAL", ACK, SETTING, "set both motors to the logic of RORZE controller RC-231"),
        form("EA", SENSOR_LOGIC, QUERY, "query the logic byte of the selected motor"),
    ),
)

CMD_K = CommandSpec(
    mnemonic="K",
    title="Error output function (with KC)",
    section="10",
    scope=Scope.CONTROLLER,
    persisted_by=Persist.DW,
    default="0,00",
    forms=(
        form(
            "K{dt},{du}{dl}",
            ACK,
            SETTING,
            "watch errors DT and turn ON several output-port bits (mask) when one occurs",
            HexDigit("dt", lo=1, hi=7),
            HexDigit("du", lo=0, hi=15),
            HexDigit("dl", lo=0, hi=15),
            idempotent_override=False,  # also clears the limit and EMS status bits (§10 K)
        ),
        form(
            "K{dt},{bt}",
            ACK,
            SETTING,
            "watch errors DT and turn ON one output bit",
            HexDigit("dt", lo=1, hi=7),
            Dec("bt", lo=0, hi=7, digits=1),
            idempotent_override=False,  # also clears the limit and EMS status bits (§10 K)
        ),
        form("K0", ACK, SETTING, "disable the function (default)"),
        # KC clears the limit/EMS status bits and the outputs an error turned on (§10 K IV)
        form("KC", ACK, ACTION, "turn OFF the output bits set by K forms I/II"),
        form("K", ERROR_OUTPUT, QUERY, "query the setting"),
    ),
)

CMD_P = CommandSpec(
    mnemonic="P",
    title="Output-port bit ON for a set time",
    section="10",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "P{bt}{time}",
            ACK,
            ACTION,
            "turn an output bit ON for TIME, then OFF",
            Dec("bt", lo=0, hi=7, digits=1),
            Dec("time", lo=0, hi=32767, digits=5),
        ),
    ),
)

CMD_T = CommandSpec(
    mnemonic="T",
    title="Internal timer (T / T*)",
    section="10",
    scope=Scope.CONTROLLER,
    user_program=False,
    forms=(
        form(
            "T{time}",
            ACK_THEN_TIMER,
            ACTION,
            "set the timer and start it; report time-up",
            Dec("time", lo=0, hi=32767, digits=5),
        ),
        form(
            "T*{time}",
            ACK,
            ACTION,
            "(T*) set and start the timer without time-up message",
            Dec("time", lo=0, hi=32767, digits=5),
        ),
        form("T", DIGIT, QUERY, "query whether the timer has timed up"),
    ),
)


COMMANDS: tuple[CommandSpec, ...] = (
    CMD_C,
    CMD_CI,
    CMD_CL,
    CMD_CO,
    CMD_D,
    CMD_DS,
    CMD_EA,
    CMD_K,
    CMD_P,
    CMD_T,
)
