"""Mode, motor selection, speed and step-out settings (§10 E ... RD).

Facts from the RC-233 manual, chapter 10; see docs/manual-notes.md for the choices made where
the manual is ambiguous.
"""

from __future__ import annotations

from gateway.protocol.params import Dec, IntChoice
from gateway.protocol.spec import CommandSpec, Effect, Persist, ReplyFormat, Scope, form

ACK = ReplyFormat.ACK
MOTOR_PAIR = ReplyFormat.MOTOR_PAIR
DEC3 = ReplyFormat.DEC3
DEC5 = ReplyFormat.DEC5
DIGIT = ReplyFormat.DIGIT
ACTION = Effect.ACTION
QUERY = Effect.QUERY
SETTING = Effect.SETTING

#: The step-out period page marks E0 ○ E1 × E2 ○ (§10 Q; §13 "usable in mode 2 too").
MODES_0_2 = frozenset({0, 2})

CMD_E = CommandSpec(
    mnemonic="E",
    title="Operating mode",
    section="10",
    scope=Scope.SHARED,
    while_moving=False,
    persisted_by=Persist.DW,
    default="0",
    forms=(
        form("E{mode}", ACK, SETTING, "set the operating mode", Dec("mode", lo=0, hi=2, digits=1)),
        form("E", DIGIT, QUERY, "query the operating mode"),
    ),
)

CMD_ED = CommandSpec(
    mnemonic="ED",
    title="Pulse output method (2P CW/CCW or PULSE & DIR)",
    section="10",
    scope=Scope.SHARED,
    while_moving=False,
    persisted_by=Persist.DW,
    default="1",
    forms=(
        form("ED1", ACK, SETTING, "2P (2CK) method: separate CW and CCW pulse outputs (default)"),
        form("ED0", ACK, SETTING, "PULSE & DIR (1CK) method"),
        form("ED", DIGIT, QUERY, "query the pulse output method"),
    ),
)

CMD_EP = CommandSpec(
    mnemonic="EP",
    title="Position management range (unsigned / signed)",
    section="10",
    scope=Scope.SHARED,
    modes=frozenset({0, 2}),
    while_moving=False,
    persisted_by=Persist.DW,
    default="0",
    forms=(
        form("EP1", ACK, SETTING, "signed management, -8,388,608..+8,388,607"),
        form("EP0", ACK, SETTING, "unsigned management, 0..16,777,215 (default)"),
        form("EP", DIGIT, QUERY, "query the management range"),
    ),
)

CMD_F = CommandSpec(
    mnemonic="F",
    title="Select target motor",
    section="10",
    scope=Scope.CONTROLLER,
    while_moving=False,
    default="1",
    forms=(
        form(
            "F{mt}",
            ACK,
            SETTING,
            "select the motor that later commands act on",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
        form("F", DIGIT, QUERY, "query the selected motor"),
    ),
)

CMD_OC = CommandSpec(
    mnemonic="OC",
    title="S-curve rate",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    persisted_by=Persist.DW,
    default="0",
    forms=(
        form(
            "OC{dt}",
            ACK,
            SETTING,
            "set the S-curve rate of the acceleration/deceleration sections",
            Dec("dt", lo=0, hi=100, digits=3),
        ),
        form("OC", DEC3, QUERY, "query the S-curve rate (of the selected motor)"),
    ),
)

CMD_OH = CommandSpec(
    mnemonic="OH",
    title="High speed (OHI/OHD)",
    section="10",
    scope=Scope.PER_MOTOR,
    persisted_by=Persist.DW,
    default="5000",
    forms=(
        form("OH{hs}", ACK, SETTING, "set High speed", Dec("hs", lo=1, hi=16383, digits=5)),
        form("OH", DEC5, QUERY, "query High speed (of the selected motor)"),
        form(
            "OHI{id}",
            ACK,
            ACTION,
            "(OHI) increment High speed",
            Dec("id", lo=1, hi=16382, digits=5),
        ),
        form(
            "OHD{dd}",
            ACK,
            ACTION,
            "(OHD) decrement High speed",
            Dec("dd", lo=1, hi=16382, digits=5),
        ),
    ),
)

CMD_OL = CommandSpec(
    mnemonic="OL",
    title="Low speed (start speed and homing speed; OLI/OLD)",
    section="10",
    scope=Scope.PER_MOTOR,
    persisted_by=Persist.DW,
    default="500",
    forms=(
        form("OL{ls}", ACK, SETTING, "set Low speed", Dec("ls", lo=1, hi=16383, digits=5)),
        form("OL", DEC5, QUERY, "query Low speed (of the selected motor)"),
        form(
            "OLI{id}", ACK, ACTION, "(OLI) increment Low speed", Dec("id", lo=1, hi=16382, digits=5)
        ),
        form(
            "OLD{dd}", ACK, ACTION, "(OLD) decrement Low speed", Dec("dd", lo=1, hi=16382, digits=5)
        ),
    ),
)

CMD_OS = CommandSpec(
    mnemonic="OS",
    title="Acceleration data (OSI/OSD)",
    section="10",
    scope=Scope.PER_MOTOR,
    persisted_by=Persist.DW,
    default="300",
    forms=(
        form("OS{ss}", ACK, SETTING, "set acceleration data", Dec("ss", lo=1, hi=32767, digits=5)),
        form("OS", DEC5, QUERY, "query acceleration data (of the selected motor)"),
        form("OSI{id}", ACK, ACTION, "(OSI) increment", Dec("id", lo=1, hi=32765, digits=5)),
        form("OSD{dd}", ACK, ACTION, "(OSD) decrement", Dec("dd", lo=1, hi=32765, digits=5)),
    ),
)

CMD_OX = CommandSpec(
    mnemonic="OX",
    title="Frequency-multiplier data",
    section="10",
    scope=Scope.SHARED,
    persisted_by=Persist.DW,
    default="300",
    forms=(
        form(
            "OX{xs}",
            ACK,
            SETTING,
            "set the data that fixes the frequency multiplier",
            Dec("xs", lo=2, hi=16383, digits=5),
        ),
        form("OX", DEC5, QUERY, "query the OX data"),
    ),
)

CMD_PA = CommandSpec(
    mnemonic="PA",
    title="Encoder multiplication (x1/x2/x4)",
    section="10",
    scope=Scope.PER_MOTOR,
    # E0 too: QSE (mode 0) needs PA and PB set first (§10 QSE); docs/manual-notes.md
    modes=frozenset({0, 1}),
    persisted_by=Persist.DW,
    default="1",
    forms=(
        form(
            "PA{dt}",
            ACK,
            SETTING,
            "set the encoder input multiplication",
            IntChoice("dt", values=(1, 2, 4)),
        ),
        form("PA", DIGIT, QUERY, "query (of the selected motor)"),
    ),
)

CMD_PB = CommandSpec(
    mnemonic="PB",
    title="Encoder-to-motor pulse ratio",
    section="10",
    scope=Scope.PER_MOTOR,
    # E0 too: QSE (mode 0) needs PA and PB set first (§10 QSE); docs/manual-notes.md
    modes=frozenset({0, 1}),
    while_moving=False,
    persisted_by=Persist.DW,
    default="10",
    forms=(
        form(
            "PB{ra}",
            ACK,
            SETTING,
            "set how many output pulses correspond to one encoder pulse",
            Dec("ra", lo=1, hi=255, digits=3),
        ),
        form("PB", DEC3, QUERY, "query (of the selected motor)"),
    ),
)

CMD_Q = CommandSpec(
    mnemonic="Q",
    title="Step-out query; step-out sensor ON/OFF period",
    section="10",
    scope=Scope.PER_MOTOR,
    persisted_by=Persist.DW,
    default="400",
    notes=("the default and DW persistence belong to the period Q{s1} (§10 DW list, §16)",),
    forms=(
        form("Q", DIGIT, QUERY, "query whether a step-out has been detected"),
        form(
            "Q{s1}",
            ACK,
            SETTING,
            "set the pulses of one ON/OFF period of the step-out sensor",
            Dec("s1", lo=100, hi=65535, digits=5),
            modes=MODES_0_2,
        ),
        form("QD", DEC5, QUERY, "(QD) query the period of the selected motor", modes=MODES_0_2),
        form(
            "QD{mt}",
            DEC5,
            QUERY,
            "(QD{MT}) query the period of a given motor",
            IntChoice("mt", values=(1, 2)),
            modes=MODES_0_2,
        ),
    ),
)

CMD_QE = CommandSpec(
    mnemonic="QE",
    title="Step-out deviation window (encoder)",
    section="10",
    scope=Scope.SHARED,
    modes=frozenset({0, 1}),
    persisted_by=Persist.DW,
    default="4",
    forms=(
        form(
            "QE{dt}",
            ACK,
            SETTING,
            "set the allowed deviation between pulse data and encoder count",
            Dec("dt", lo=0, hi=9, digits=1),
        ),
        form("QE", DIGIT, QUERY, "query"),
    ),
)

CMD_QJ = CommandSpec(
    mnemonic="QJ",
    title="Encoder adjust function (QJR/QJT/QJA/QJO)",
    section="10",
    scope=Scope.SHARED,
    modes=frozenset({1}),
    persisted_by=Persist.DW,
    default="QJ 00, QJT 3, QJA 800, QJO 0",
    forms=(
        form(
            "QJ{m2}{m1}",
            ACK,
            SETTING,
            "enable/disable adjust per motor",
            IntChoice("m2", values=(0, 1)),
            IntChoice("m1", values=(0, 1)),
        ),
        form("QJ", MOTOR_PAIR, QUERY, "query the adjust setting"),
        form("QJR", ACK, SETTING, "(QJR) disable adjust for both motors"),
        form(
            "QJT{time}",
            ACK,
            SETTING,
            "(QJT) set the delay from end of motion to adjust",
            Dec("time", lo=1, hi=999, digits=3),
        ),
        form("QJT", DEC3, QUERY, "(QJT) query the delay"),
        form(
            "QJA{pp}",
            ACK,
            SETTING,
            "(QJA) set the maximum adjust travel (Ver 1.19+)",
            Dec("pp", lo=1, hi=65535, digits=5),
        ),
        form("QJA", DEC5, QUERY, "(QJA) query (Ver 1.19+)"),
        form(
            "QJO{ps}",
            ACK,
            SETTING,
            "(QJO) set the adjust speed (Ver 1.19+)",
            Dec("ps", lo=0, hi=16382, digits=5),
        ),
        form("QJO", DEC5, QUERY, "(QJO) query (Ver 1.19+)"),
    ),
)

CMD_QS = CommandSpec(
    mnemonic="QS",
    title="Step-out detection on/off (QSR)",
    section="10",
    scope=Scope.SHARED,
    persisted_by=Persist.DW,
    default="00",
    forms=(
        form(
            "QS{m2}{m1}",
            ACK,
            SETTING,
            "set step-out detection for each motor",
            IntChoice("m2", values=(0, 1, 2)),
            IntChoice("m1", values=(0, 1, 2)),
        ),
        form("QS", MOTOR_PAIR, QUERY, "query"),
        form("QSR", ACK, SETTING, "(QSR) cancel detection for both motors"),
    ),
)

CMD_QSE = CommandSpec(
    mnemonic="QSE",
    title="Encoder step-out detection in mode 0 (QSER)",
    section="10",
    scope=Scope.SHARED,
    modes=frozenset({0}),
    default="00",
    forms=(
        form(
            "QSE{m2}{m1}",
            ACK,
            SETTING,
            "set encoder-based step-out detection per motor",
            IntChoice("m2", values=(0, 1)),
            IntChoice("m1", values=(0, 1)),
        ),
        form("QSE", MOTOR_PAIR, QUERY, "query"),
        form("QSER", ACK, SETTING, "(QSER) cancel for both motors"),
    ),
)

CMD_RD = CommandSpec(
    mnemonic="RD",
    title="Release step-out error (mode 1)",
    section="10",
    scope=Scope.CONTROLLER,
    modes=frozenset({1}),
    forms=(form("RD", ACK, SETTING, "clear the step-out error"),),
)


COMMANDS: tuple[CommandSpec, ...] = (
    CMD_E,
    CMD_ED,
    CMD_EP,
    CMD_F,
    CMD_OC,
    CMD_OH,
    CMD_OL,
    CMD_OS,
    CMD_OX,
    CMD_PA,
    CMD_PB,
    CMD_Q,
    CMD_QE,
    CMD_QJ,
    CMD_QS,
    CMD_QSE,
    CMD_RD,
)
