"""User programs (chapters 11-12): program text to typed statements, and back.

A program is the text a host uploads after ``I``: statements, each introduced by '/', e.g.
``/D00/0//D01B/JON0+1/J-2/D00/25000/3//END``. ``parse_program`` turns it into a ``Program``
of ``Statement``s (each a step number and the command model ``parse_statement`` gives), and
``Program.text()`` writes it back. A ``Program`` is valid from the moment it exists: every
rule of chapters 11-12 that can be checked without running it is checked on construction and
broken rules raise ``ProgramError`` naming the step.

Steps count the way the device's ``GN`` does (§10 GN): the number of '/' from the first
statement's '/' up to and including this statement's '/'. Every statement starts with exactly
one '/', so the step is the statement's 1-based index, and ``//`` (a command followed by the
empty NULL wait) is two steps. Step 0 means "no statement": refusals about the whole text.

Uploading is not this module's business (no I/O); ``upload_chunks`` only cuts the text into
pieces for the transport to send. Decisions where the manual is silent: docs/manual-notes.md,
"User programs".
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType

from gateway.errors import InvalidInputError, ProgramError
from gateway.protocol.command_text import parse_statement
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.protocol.text_params import Jump, jump_count

__all__ = [
    "CAPACITY_BYTES",
    "Program",
    "ProgramRule",
    "Statement",
    "parse_program",
    "upload_chunks",
]

#: RAM program capacity (§1 specifications, §10 I, §10 IR): the text without its final CR.
CAPACITY_BYTES = 4416


class ProgramRule(StrEnum):
    """The program-level rules, in words; the ``rule`` of the ``ProgramError`` they raise."""

    EMPTY = "a program has at least one statement (§10 I)"
    FIRST_CHARACTER = "the first character of a program is '/' (§10 I)"
    DOLLAR = "no '$' anywhere in a program: '$' starts a host command (§10 I, §11-3)"
    CR = "no CR inside a program: the first CR ends the transfer (§10 I)"
    STEPS = "statements are numbered 1, 2, 3 ... as GN counts them (§10 GN)"
    CHARACTERS = "one-byte JIS X 0201 characters only: ASCII, '¥', half-width katakana"
    CAPACITY = f"at most {CAPACITY_BYTES:,} bytes (§10 I)"
    DUPLICATE_LABEL = "each label '/G<label>' once, so that jumps and G<label> are unambiguous"
    MISSING_LABEL = "G<label>n needs '/G<label>' in the program (§12 JUMP table: command error)"
    OUTSIDE = "a jump or call lands on a statement of the program (§12 JUMP table)"
    END = "'/END' is the last statement of a program (§11-3 note, §12 /END)"
    NOT_A_JUMP = "only jump and call statements have a target (§12 JUMP table)"
    HOST_LOWER_CASE = "the host cannot start a program at a lower-case label (§10 G, Ver 1.18)"
    HOST_MISSING = "the host can start a program only at a label it contains (§10 G)"


#: The first '$' or CR: both break the transfer itself, so they are found before any parsing.
_FORBIDDEN = re.compile(r"[$\r]")


def _one_byte(char: str) -> bool:
    """Whether ``char`` is one JIS X 0201 byte on the wire.

    The controller's line is 8-bit JIS X 0201: ASCII (with '¥' U+00A5 and '‾' U+203E as the
    JIS spellings of 0x5C and 0x7E) and half-width katakana 0xA1-0xDF. Counting characters
    this way, not UTF-8 bytes, is what makes ``/Gｱ`` 3 bytes, as the device stores it.
    """
    code = ord(char)
    return code < 0x80 or code in (0xA5, 0x203E) or 0xFF61 <= code <= 0xFF9F


@dataclass(frozen=True)
class Statement:
    """One statement: its step (as ``GN`` counts it) and its command model."""

    step: int
    command: Command

    def text(self) -> str:
        """The statement as it stands in the program, '/' included (``/J-2``, ``/``)."""
        return "/" + self.command.wire()

    @property
    def label(self) -> str | None:
        """The label this statement declares (``/G1`` -> ``"1"``), or None."""
        if self.command.spec.mnemonic == "/G":
            return str(self.command.params()["lb"])
        return None

    @property
    def jump(self) -> str | None:
        """The jump operand of a jump or call (``+1``, ``-7``, ``A1``, ``G11``), or None."""
        # Every jump of §12 (/J, /JB.., /JC.., /JE.., /JM, /JO.., /JP, /JR.., /JT, /SC)
        # carries exactly one Jump parameter; asking the form keeps this list in the catalog.
        for param in self.command.form.params:
            if isinstance(param, Jump):
                return str(getattr(self.command, param.name))
        return None

    @property
    def is_end(self) -> bool:
        """Whether this statement is ``/END``."""
        return self.command.spec.mnemonic == "/END"


@dataclass(frozen=True)
class Program:
    """A user program whose statically checkable rules all hold (chapters 11-12).

    Construct it with ``parse_program(text)`` or ``Program.from_commands(...)``; building it
    from statements directly runs the same checks.
    """

    statements: tuple[Statement, ...]
    #: label -> step of its '/G<label>' statement
    labels: Mapping[str, int] = field(init=False, repr=False, compare=False)
    _targets: Mapping[int, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.statements:
            raise ProgramError("empty program", step=0, field="text", rule=ProgramRule.EMPTY)
        labels: dict[str, int] = {}
        size = 0
        for index, statement in enumerate(self.statements, 1):
            if statement.step != index:
                raise ProgramError(
                    f"statement {index} says it is step {statement.step}",
                    step=index,
                    field="step",
                    rule=ProgramRule.STEPS,
                )
            text = statement.text()
            odd = next((c for c in text if not _one_byte(c)), None)
            if odd is not None:
                raise ProgramError(
                    f"{odd!r} in {text!r} has no one-byte code on the wire",
                    step=index,
                    field="text",
                    rule=ProgramRule.CHARACTERS,
                )
            size += len(text)  # one byte per character, checked just above
            if size > CAPACITY_BYTES:
                # Name the first statement that does not fit: that is where to cut.
                raise ProgramError(
                    f"{text!r} ends at byte {size:,}, beyond the {CAPACITY_BYTES:,} of RAM",
                    step=index,
                    field="text",
                    rule=ProgramRule.CAPACITY,
                )
            label = statement.label
            if label is not None:
                if label in labels:
                    raise ProgramError(
                        f"label {label!r} is declared again (first at step {labels[label]})",
                        step=index,
                        field="lb",
                        rule=ProgramRule.DUPLICATE_LABEL,
                    )
                labels[label] = index
        last = self.statements[-1]
        if not last.is_end:  # checked before jumps: a fragment is refused as a fragment
            raise ProgramError(
                f"the program ends with {last.text()!r}, not '/END'",
                step=last.step,
                field="text",
                rule=ProgramRule.END,
            )
        object.__setattr__(self, "labels", MappingProxyType(labels))
        object.__setattr__(self, "_targets", MappingProxyType(self._resolve(labels)))

    def _resolve(self, labels: Mapping[str, int]) -> dict[int, int]:
        """The step each jump or call lands on, with the origins of the §12 JUMP table."""
        targets: dict[int, int] = {}
        for statement in self.statements:
            operand = statement.jump
            if operand is None:
                continue
            count = jump_count(operand)
            step = statement.step
            kind = operand[0]
            # How the target was counted, said in the refusal when it lands outside.
            if kind == "+":  # the statement after the jump is 0: +1 skips one (§12 /J +1)
                target = step + 1 + count
                counted = f"{count} on from step {step + 1}, the statement after it"
            elif kind == "-":  # same origin backwards: -1 is the jump itself, -2 the one before
                target = step + 1 - count
                counted = f"{count} back from step {step + 1}, the statement after it"
            elif kind == "A":  # absolute: the first statement is 1 (§12 /J A1)
                target = count
                counted = f"step {count} counted from the first statement"
            else:  # G<label>n: the label statement is 0, G<label>1 the one after it
                label = operand[1]
                if label not in labels:
                    raise ProgramError(
                        f"{statement.text()!r} jumps to label {label!r}, which is not declared",
                        step=step,
                        field="jump",
                        rule=ProgramRule.MISSING_LABEL,
                    )
                target = labels[label] + count
                counted = f"{count} on from label {label!r} at step {labels[label]}"
            if not 1 <= target <= len(self.statements):
                raise ProgramError(
                    f"{statement.text()!r} lands on step {target} ({counted}), but the "
                    f"program has steps 1-{len(self.statements)} only",
                    step=step,
                    field="jump",
                    rule=ProgramRule.OUTSIDE,
                )
            targets[step] = target
        return targets

    @classmethod
    def from_commands(cls, commands: Iterable[Command]) -> Program:
        """A program of these commands in order, numbered as ``GN`` counts them."""
        return cls(tuple(Statement(step, c) for step, c in enumerate(commands, 1)))

    def text(self) -> str:
        """The program text, without the CR that ends an upload."""
        return "".join(s.text() for s in self.statements)

    @property
    def size_bytes(self) -> int:
        """Bytes on the wire (one per character, JIS X 0201), at most ``CAPACITY_BYTES``."""
        return len(self.text())

    @property
    def step_count(self) -> int:
        """The ``GN`` of the last statement (the last ``/END``)."""
        return len(self.statements)

    def statement(self, step: int) -> Statement:
        """The statement at ``step`` (1 = the first)."""
        if not 1 <= step <= len(self.statements):
            raise ProgramError(
                f"no step {step} in a program of {len(self.statements)} steps",
                step=step,
                field="step",
                rule=ProgramRule.STEPS,
            )
        return self.statements[step - 1]

    def target(self, step: int) -> int:
        """The step the jump or call at ``step`` lands on (when its condition holds)."""
        found = self._targets.get(step)
        if found is None:
            text = self.statement(step).text()  # refuses a step outside the program first
            raise ProgramError(
                f"{text!r} is not a jump or call",
                step=step,
                field="step",
                rule=ProgramRule.NOT_A_JUMP,
            )
        return found

    def host_start(self, label: str) -> int:
        """Check that the host may send ``G{label}``; the first step it runs.

        Execution starts at the statement after ``/G{label}`` (§10 G). Lower-case labels exist
        for jumps only (Ver 1.18), and a missing label is an error on the device.
        """
        step = self.labels.get(label)
        if len(label) == 1 and "a" <= label <= "z":
            raise ProgramError(
                f"G{label}: lower-case labels are jump targets only",
                step=step or 0,
                field="lb",
                rule=ProgramRule.HOST_LOWER_CASE,
            )
        if step is None:
            raise ProgramError(
                f"G{label}: no '/G{label}' in the program",
                step=0,
                field="lb",
                rule=ProgramRule.HOST_MISSING,
            )
        return step + 1  # never past the end: the last statement is /END, not a label


def parse_program(text: str, *, positions: PositionFormat | None = None) -> Program:
    """Parse program text (``/``-separated statements, no CR) into a valid ``Program``.

    ``positions`` is the controller's position management, when known (see ``models``).
    """
    if not text:
        raise ProgramError("empty program", step=0, field="text", rule=ProgramRule.EMPTY)
    if text[0] != "/":
        # The device answers '>' at once and flags a command error (§10 I): nothing is stored.
        raise ProgramError(
            f"the program starts with {text[0]!r}",
            step=0,
            field="text",
            rule=ProgramRule.FIRST_CHARACTER,
        )
    bad = _FORBIDDEN.search(text)
    if bad is not None:
        dollar = bad.group() == "$"
        raise ProgramError(
            f"{'$' if dollar else 'CR'} at character {bad.start() + 1}",
            step=text.count("/", 0, bad.start()),  # the statement holding it, as GN counts
            field="text",
            rule=ProgramRule.DOLLAR if dollar else ProgramRule.CR,
        )
    statements: list[Statement] = []
    for step, body in enumerate(text[1:].split("/"), 1):
        try:
            command = parse_statement(body, positions=positions)
        except InvalidInputError as exc:
            raise ProgramError(
                f"/{body}: {exc}", step=step, field=exc.field, rule=exc.rule
            ) from exc
        statements.append(Statement(step, command))
    return Program(tuple(statements))


def upload_chunks(program: Program, max_chunk: int) -> list[str]:
    """The program text in pieces of at most ``max_chunk`` bytes, for the upload after ``I``.

    The device joins pieces sent at different times into one program, and the first CR ends
    the transfer (§10 I), so no piece holds a CR: the caller sends CR after the last piece.
    Pieces end at statement boundaries where a statement fits (as ch. 13-2 splits its
    example), so that a log of the upload reads statement by statement.
    """
    if max_chunk < 1:
        raise ValueError(f"max_chunk must be at least 1, got {max_chunk}")
    chunks: list[str] = []
    current = ""
    for statement in program.statements:
        piece = statement.text()
        if len(current) + len(piece) > max_chunk and current:
            chunks.append(current)
            current = ""
        while len(piece) > max_chunk:  # a statement longer than a chunk is cut anywhere
            chunks.append(piece[:max_chunk])
            piece = piece[max_chunk:]
        current += piece
    chunks.append(current)
    return chunks
