"""The jumps, calls and ends of user programs (§12 /G, /J*, /SC, /SR, /END, /?, /).

Facts from the RC-233 manual, chapter 12; see docs/manual-notes.md for the choices made where
the manual is ambiguous. ``program_only`` lists them in the manual's order.
"""

from __future__ import annotations

from gateway.protocol.params import (
    CharChoice,
    Dec,
    HexDigit,
    IntChoice,
    Position,
)
from gateway.protocol.spec import CommandSpec, Effect, ReplyFormat, Scope, form
from gateway.protocol.text_params import Jump, Label

__all__ = [
    "CMD_P_",
    "CMD_P_END",
    "CMD_P_G",
    "CMD_P_J",
    "CMD_P_JB",
    "CMD_P_JC",
    "CMD_P_JE",
    "CMD_P_JM",
    "CMD_P_JO",
    "CMD_P_JP",
    "CMD_P_JR",
    "CMD_P_JT",
    "CMD_P_SC",
    "CMD_P_SR",
    "CMD_P__",
]

NONE = ReplyFormat.NONE
ACTION = Effect.ACTION


CMD_P_ = CommandSpec(
    mnemonic="/",
    title="Wait for motor stop (NULL command)",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("", NONE, ACTION, "wait until motion has ended"),),
)

CMD_P_END = CommandSpec(
    mnemonic="/END",
    title="End of program",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("END", NONE, ACTION, "end execution"),),
)

CMD_P_G = CommandSpec(
    mnemonic="/G",
    title="Label",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("G{lb}", NONE, ACTION, "label command", Label("lb")),),
)

CMD_P_J = CommandSpec(
    mnemonic="/J",
    title="Unconditional jump",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("J{jump}", NONE, ACTION, "jump", Jump("jump")),),
)

CMD_P_JB = CommandSpec(
    mnemonic="/JB",
    title="Jump on data-buffer bit",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "JBON{bf}{bt}{jump}",
            NONE,
            ACTION,
            "jump if the bit is 1",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            Dec("bt", lo=0, hi=7, digits=1),
            Jump("jump"),
        ),
        form(
            "JBOF{bf}{bt}{jump}",
            NONE,
            ACTION,
            "jump if the bit is 0",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            Dec("bt", lo=0, hi=7, digits=1),
            Jump("jump"),
        ),
    ),
)

CMD_P_JC = CommandSpec(
    mnemonic="/JC",
    title="Jump on counter",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "JC{ct}{jump}",
            NONE,
            ACTION,
            "jump if the counter is 0",
            IntChoice("ct", values=(1, 2)),
            Jump("jump"),
        ),
        form(
            "JC{ct}{sn}{cn}{jump}",
            NONE,
            ACTION,
            "jump if the counter compares true",
            IntChoice("ct", values=(1, 2)),
            CharChoice("sn", values=("<", "=", ">")),
            Dec("cn", lo=0, hi=65535, digits=5),
            Jump("jump"),
        ),
    ),
)

CMD_P_JE = CommandSpec(
    mnemonic="/JE",
    title="Jump on error",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form("JE{jump}", NONE, ACTION, "jump if any error bit is set", Jump("jump")),
        form(
            "JE{bt}{jump}",
            NONE,
            ACTION,
            "jump if a given error bit is set",
            IntChoice("bt", values=(0, 1, 2, 6)),
            Jump("jump"),
        ),
    ),
)

CMD_P_JM = CommandSpec(
    mnemonic="/JM",
    title="Jump while a motor is moving",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("JM{jump}", NONE, ACTION, "jump if motor 1 or 2 is moving", Jump("jump")),),
)

CMD_P_JO = CommandSpec(
    mnemonic="/JO",
    title="Jump on input",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "JON{bt}{jump}",
            NONE,
            ACTION,
            "jump if the input is ON",
            CharChoice("bt", values=tuple("0123456789ABC")),
            Jump("jump"),
        ),
        form(
            "JOF{bt}{jump}",
            NONE,
            ACTION,
            "jump if the input is OFF",
            CharChoice("bt", values=tuple("0123456789ABC")),
            Jump("jump"),
        ),
    ),
)

CMD_P_JP = CommandSpec(
    mnemonic="/JP",
    title="Jump on position comparison",
    section="12",
    scope=Scope.PER_MOTOR,
    forms=(
        form(
            "JP{mt}{sn}{pj}{jump}",
            NONE,
            ACTION,
            "jump if the motor position compares true",
            IntChoice("mt", values=(1, 2)),
            CharChoice("sn", values=("<", "=", ">")),
            Position("pj"),
            Jump("jump"),
        ),
    ),
)

CMD_P_JR = CommandSpec(
    mnemonic="/JR",
    title="Jump on data-buffer comparison",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "JR{bf}{sn}{du}{dl}{jump}",
            NONE,
            ACTION,
            "compare a buffer with a byte",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            CharChoice("sn", values=("<", "=", ">")),
            HexDigit("du", lo=0, hi=15),
            HexDigit("dl", lo=0, hi=15),
            Jump("jump"),
        ),
        form(
            "JR{bf}{sn}R{b2}{jump}",
            NONE,
            ACTION,
            "compare two buffers",
            CharChoice("bf", values=("A", "B", "C", "D", "E", "F")),
            CharChoice("sn", values=("<", "=", ">")),
            CharChoice("b2", values=("A", "B", "C", "D", "E", "F")),
            Jump("jump"),
        ),
    ),
)

CMD_P_JT = CommandSpec(
    mnemonic="/JT",
    title="Jump while /TB timer counts",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(
        form(
            "JT{jump}",
            NONE,
            ACTION,
            "jump if the timer started by /TB is still counting",
            Jump("jump"),
        ),
    ),
)

CMD_P_SC = CommandSpec(
    mnemonic="/SC",
    title="Subroutine call",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("SC{jump}", NONE, ACTION, "call a subroutine", Jump("jump")),),
)

CMD_P_SR = CommandSpec(
    mnemonic="/SR",
    title="Subroutine return",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("SR", NONE, ACTION, "return from a subroutine"),),
)

CMD_P__ = CommandSpec(
    mnemonic="/?",
    title="End program on error",
    section="12",
    scope=Scope.CONTROLLER,
    forms=(form("?", NONE, ACTION, "end the program if an error is present"),),
)
