"""The position table and the moves to its entries (§10 A, B, B+(-)).

Facts from the RC-233 manual, chapter 10; see docs/manual-notes.md for the choices made where
the manual is ambiguous. ``motion`` lists them in the manual's order.
"""

from __future__ import annotations

from gateway.protocol.params import CharChoice, Digits, IntChoice, Position
from gateway.protocol.spec import CommandSpec, Effect, Persist, ReplyFormat, Scope, form

__all__ = ["CMD_A", "CMD_B", "CMD_BPM"]

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


CMD_A = CommandSpec(
    mnemonic="A",
    title="Position table (1000 points) for B and B+(-)",
    section="10",
    scope=Scope.SHARED,
    persisted_by=Persist.AW,
    default="0",
    forms=(
        form(
            "A{pn}{pp}",
            ACK,
            SETTING,
            "set the position pulse count of position number pn",
            Digits("pn", lo=0, hi=999, digits=3),
            Position("pp"),
        ),
        form(
            "A{pn}",
            ACK,
            SETTING,
            "store the current position as entry pn",
            Digits("pn", lo=0, hi=999, digits=3),
        ),
        form("A{pn}D", POSITION, QUERY, "query entry pn", Digits("pn", lo=0, hi=999, digits=3)),
    ),
)

CMD_B = CommandSpec(
    mnemonic="B",
    title="Absolute move to a position-table entry (with sequential mode and next-number query BN)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form(
            "B{pn}",
            ACK,
            MOTION,
            "move the selected motor to the position of entry pn",
            Digits("pn", lo=0, hi=999, digits=3),
        ),
        form(
            "B{pn}{mt}",
            ACK,
            MOTION,
            "select motor MT and move it to the position of entry pn",
            Digits("pn", lo=0, hi=999, digits=3),
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
        form(
            "B", ACK, MOTION, "move to the entry following the one used by the previous B / B+(-)"
        ),
        form(
            "B{mt}",
            ACK,
            MOTION,
            "select motor MT and move it to the next entry",
            IntChoice("mt", values=(1, 2)),
            selects_motor=True,
        ),
        form(
            "BN",
            DEC5,
            QUERY,
            "query the position number the next sequential B / B+(-) will use (BN)",
        ),
    ),
)

CMD_BPM = CommandSpec(
    mnemonic="B+(-)",
    title="Incremental move by a position-table entry (+ = CW, - = CCW)",
    section="10",
    scope=Scope.PER_MOTOR,
    while_moving=False,
    forms=(
        form(
            "B{pn}{dir}",
            ACK,
            MOTION,
            "move the selected motor relatively by |A[pn]| CW (+) or CCW (-)",
            Digits("pn", lo=0, hi=999, digits=3),
            CharChoice("dir", values=("+", "-")),
        ),
        form(
            "B{pn}{mt}{dir}",
            ACK,
            MOTION,
            "select motor MT and move it relatively by |A[pn]|",
            Digits("pn", lo=0, hi=999, digits=3),
            IntChoice("mt", values=(1, 2)),
            CharChoice("dir", values=("+", "-")),
            selects_motor=True,
        ),
        form(
            "B{dir}",
            ACK,
            MOTION,
            "relative move by the next entry after the previous B / B+(-)",
            CharChoice("dir", values=("+", "-")),
        ),
        form(
            "B{mt}{dir}",
            ACK,
            MOTION,
            "select motor MT and move it by the next entry",
            IntChoice("mt", values=(1, 2)),
            CharChoice("dir", values=("+", "-")),
            selects_motor=True,
        ),
    ),
)
