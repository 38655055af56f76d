"""What the manual says about each command: the catalog's vocabulary.

``CommandSpec`` holds one mnemonic of chapter 10 or 12 (``OH``, ``B+(-)``, ``/JC``) with the
facts of its table row; ``Form`` holds one way of writing it (``OH{hs}``, ``OH``, ``OHI{id}``)
with the facts that differ between forms: reply, effect, idempotency, motor selection.
The catalog modules fill these in; ``models`` turns each form into a pydantic model and
``registry`` parses text back into those models.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from enum import StrEnum
from functools import cached_property

from gateway.protocol.params import IntChoice, Param, Position

__all__ = [
    "ALL_MODES",
    "CommandSpec",
    "Effect",
    "Form",
    "Persist",
    "ReplyFormat",
    "Scope",
    "form",
]

ALL_MODES = frozenset({0, 1, 2})


class Scope(StrEnum):
    """Whose value a command reads or writes (§10 F list, §10 per-command tables)."""

    PER_MOTOR = "per_motor"  # one value per motor, or acts on the selected motor
    SHARED = "shared"  # one value for both motors
    CONTROLLER = "controller"  # not motor related: I/O, communication, EEPROM, flags


class Persist(StrEnum):
    """The EEPROM write that keeps a setting over a power cycle (§10 DW list, §16)."""

    NONE = "none"
    DW = "DW"
    AW = "AW"
    IW = "IW"
    ES = "ES"
    GA = "GA"


class Effect(StrEnum):
    """What sending a form does; decides whether it may be sent again after a lost reply."""

    QUERY = "query"  # reads; changes nothing (but see Form.clears_on_read)
    SETTING = "setting"  # stores an absolute value: sending it twice leaves the same state
    MOTION = "motion"  # starts motor motion: moves, homing, jogs, single pulses
    STOP = "stop"  # stops motion or a program: sending it twice is harmless
    ACTION = "action"  # happens once per send: increments, timers, uploads, EEPROM writes


class ReplyFormat(StrEnum):
    """The shape of a form's reply (§9-2 and each command's reply box).

    Data formats name the part between ``>$B#`` and CR; ``replies`` decodes and encodes them.
    """

    ACK = "ack"  # '>' (communication normal; not "command valid")
    ACK_THEN_DONE = "ack_then_done"  # '>' now, '$B#*' CR when the EEPROM write/erase ends
    ACK_THEN_TIMER = "ack_then_timer"  # '>' now, '$B#T' CR at time-up (host T)
    NONE = "none"  # user-program-only statement: never sent by the host
    STATUS = "status"  # "" : one hex digit, status flags
    CONDITION = "condition"  # 9 : two hex digits, condition flags, mode, selected motor
    CONDITION_BIT = "condition_bit"  # 9{bit} : one digit (0/1, or the mode for bits 4/5)
    POSITION = "position"  # 6, 2D, A{pn}D : 8 digits (EP0) or sign + 7 digits (EP1, mode 1)
    DIGIT = "digit"  # one decimal digit (settings, single inputs, on/off states)
    DEC3 = "dec3"  # three decimal digits (OC, PB, QJT)
    DEC5 = "dec5"  # five decimal digits (speeds, counts, 0S, BN, GN, GRT)
    INPUTS = "inputs"  # C : two hex digits DU DL, general inputs 7-0
    INPUTS_INP = "inputs_inp"  # CA : IP DU DL, INP2/INP1 then general inputs
    SENSORS = "sensors"  # CL, CLM{mt} : two hex digits, sensor inputs of one motor
    OUTPUTS = "outputs"  # CO : two hex digits DU DL, general outputs 7-0
    OUTPUTS_CLR = "outputs_clr"  # COA : DC DU DL, CLR2/CLR1 then general outputs
    SENSOR_LOGIC = "sensor_logic"  # EA : two hex digits, A/B contact per sensor
    BUFFER = "buffer"  # GR{bf} : two hex digits, one user-program data buffer byte
    CLR_STATE = "clr_state"  # DS : two digits, CLR2 then CLR1
    MOTOR_PAIR = "motor_pair"  # QS, QJ, QSE : two digits, motor 2 then motor 1
    ERROR_OUTPUT = "error_output"  # K : DT ',' DU DL
    SPEED_POINT = "speed_point"  # N{PN} : 5 digits ',' 8 digits
    PROGRAM_STATE = "program_state"  # GSS : 1, 0, P or E
    PROGRAM_TEXT = "program_text"  # IR : the stored program text
    VERSION = "version"  # V : 'RC-233 Ver x.xx by RORZE (xx-xx-xx)'

    @property
    def has_data(self) -> bool:
        """True when the reply is '>$B#' data CR rather than a bare '>'."""
        return self not in _ACK_LIKE


_ACK_LIKE = frozenset(
    {ReplyFormat.ACK, ReplyFormat.ACK_THEN_DONE, ReplyFormat.ACK_THEN_TIMER, ReplyFormat.NONE}
)

_PLACEHOLDER = re.compile(r"\{(\w+)\}")


@dataclass(frozen=True)
class Form:
    """One way of writing a command, e.g. ``OH{hs}`` (set) or ``OH`` (query).

    ``syntax`` is the text between body number and CR with ``{name}`` for each parameter;
    it is also the form's identity (the JSON discriminator and the registry key).
    """

    syntax: str
    params: tuple[Param, ...]
    reply: ReplyFormat
    effect: Effect
    purpose: str
    #: the motor parameter MT changes the selected motor, as F does (§9-1, §10 F)
    selects_motor: bool = False
    #: the read clears device flags (``""``, ``9`` form I, ``GSS`` 'E'): a resend loses them
    clears_on_read: bool = False
    #: None = as the command's table row; set where a form differs (△ rows)
    while_moving: bool | None = None
    modes: frozenset[int] | None = None
    #: None = derived from ``effect``; set only where the manual says otherwise
    idempotent_override: bool | None = None
    #: the form changes how the following frames are written or answered (§10 EE, EL, ER,
    #: SUM set forms): encoder, parser and simulator switch framing after its reply
    switches_framing: bool = False
    #: the form reads the current position counter (§10 6), the one a move changes
    reads_position: bool = False
    #: the form stops motion at once or ends a program with its motion (§10 S, SS, GES):
    #: it outranks everything queued (DESIGN invariant 8). GE and GS also have effect STOP
    #: (harmless to resend) but let the motion of a running program go on, so they do not.
    is_stop: bool = False

    def __post_init__(self) -> None:
        names = _PLACEHOLDER.findall(self.syntax)
        if names != [p.name for p in self.params]:
            raise ValueError(f"{self.syntax!r}: placeholders {names} != params {self.params}")

    @cached_property  # wire() walks it for every command sent: split the syntax once
    def tokens(self) -> tuple[str | Param, ...]:
        """The syntax split into literal text and parameters, in order."""
        by_name = {p.name: p for p in self.params}
        out: list[str | Param] = []
        for i, piece in enumerate(_PLACEHOLDER.split(self.syntax)):
            if i % 2:
                out.append(by_name[piece])
            elif piece:
                out.append(piece)
        return tuple(out)

    @property
    def idempotent(self) -> bool:
        """Safe to send again when its reply was lost (DESIGN invariant 6)."""
        if self.idempotent_override is not None:
            return self.idempotent_override
        if self.effect is Effect.QUERY:
            return not self.clears_on_read
        return self.effect in (Effect.SETTING, Effect.STOP)

    @property
    def has_positions(self) -> bool:
        """True when a parameter is a position whose range depends on EP and the mode."""
        return any(isinstance(p, Position) for p in self.params)

    @property
    def motor_param(self) -> str | None:
        """The name of the motor-number parameter (``mt``), if the form has one."""
        for p in self.params:
            if p.name == "mt" and isinstance(p, IntChoice):
                return p.name
        return None


@dataclass(frozen=True)
class CommandSpec:
    """One mnemonic of the manual with the facts of its table row."""

    mnemonic: str  # as the manual names it; chapter-12 commands keep their leading '/'
    title: str
    section: str  # manual section, e.g. "10" or "12"
    forms: tuple[Form, ...]
    scope: Scope
    modes: frozenset[int] = ALL_MODES
    while_moving: bool = True
    user_program: bool = True  # the EEPROM column ○: usable as '/cmd' in a user program
    #: False for the host commands refused while a user program runs (§11-3 5.)
    while_program: bool = True
    persisted_by: Persist = Persist.NONE
    default: str | None = None  # factory setting (§16), as the manual writes it
    notes: tuple[str, ...] = field(default=())

    @property
    def program_only(self) -> bool:
        """Chapter-12 commands exist only inside user programs."""
        return self.mnemonic.startswith("/")

    def form_modes(self, form_: Form) -> frozenset[int]:
        """Modes in which ``form_`` is accepted."""
        return form_.modes if form_.modes is not None else self.modes

    def form_while_moving(self, form_: Form) -> bool:
        """Whether ``form_`` is accepted while a motor moves."""
        return form_.while_moving if form_.while_moving is not None else self.while_moving


def form(
    syntax: str,
    reply: ReplyFormat,
    effect: Effect,
    purpose: str,
    *params: Param,
    **options: object,
) -> Form:
    """Shorthand used by the catalog modules: ``form("OH{hs}", ACK, SETTING, "...", Dec(...))``."""
    return Form(syntax, params, reply, effect, purpose, **options)  # type: ignore[arg-type]
