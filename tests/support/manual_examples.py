"""The RC-233 manual's own example exchanges, as exact wire bytes (test data for the simulator).

Taken by hand from the Japanese manual (RC-233 取扱説明書, OCR text), never from the simulator's
code: chapter 8 (communication and motor check), chapter 9 (frame and reply formats), every
command section of chapter 10 with an example, the EE/EL/ER/SUM/EP reply tables, the flag
sections of "" and 9, and the §16 default table (read back with the query forms of §10/§15).
`line` is the line of RC-233_manual_ja.txt where the example (or the rule it checks) is printed.

Two tables:
- `EXAMPLES`: run against a fresh simulator by test_manual_examples.py; every step's
  reply must match byte for byte.
- `NEEDS_CONTROL`: examples whose state cannot be reached with commands alone (a sensor ON,
  EMS, line noise, a power cycle, the loop baud, unsolicited messages). `needs` says what, and
  `Step.control` names the action to take before that step's frame. Run by
  test_manual_examples.py through the control surface (`Controls`) of the `wire` fixture.

Conventions:
- `send` is exactly the frame (the manual's '¥' would be '\\'); `reply` exactly the bytes the
  host receives for that frame; `None` = the manual states nothing usable (send, don't compare).
- A general command's reply `>` (no CR, §9-2 書式 (I)) is filled in wherever the command's own
  応答 line gives it, even when the 使用例 prints only the PRINT statement.
- Steps marked "added" in `note` are not printed in the example itself but check what the
  example's text says happens (a readback with the section's own query format, or a preset with
  `R` so that positions are known). Reconstructions of OCR damage are said in `note` too.
- `wait_idle`: after this step the test waits until the motor stops (it polls "", which clears
  bits 1-3 of the status flags but not the condition flags of "9" (§10 "" 注意点)).
- `Step.control` words (several joined with "; "): "force M:SENSOR=on|off" (motor M, sensor
  cw_limit / ccw_limit / org / ez), "ems press", "noise" (the next frame is taken as noise: a
  one-shot nak), "power_cycle", "loop baud N" (the host's rate), "inputs B,B,..." (general
  inputs ON). `needs["scene"]` asks for a scene other than the default.
- In NEEDS_CONTROL, a step with `send == b""` means "send nothing: the next bytes the
  controller sends by itself are `reply`" (e.g. the `$1*` of DW), and `reply == b""` means
  "no reply at all".
- Motion examples assume the default scene of the simulator: both motors with a stroke of some
  100,000 pulses, ORG and both limits inside it, the motor starting away from the limits with
  some thousands of pulses of free travel either way (`setup` says how much each one needs).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

ACK = b">"
"""Reply to a general command: communication normal (§9-2 書式 (I)); no CR."""

VERSION_REPLY_PATTERN = rb">\$1RC-233 Ver \d\.\d\d by RORZE \(\d\d-\d\d-\d\d\)\r"
"""§10 V (line 6870): `>$B#RC-233 Ver x.xx by RORZE (xx-xx-xx)` CR; §15: 39 characters.

The OCR prints a space between every character; single spaces between the words are what makes
the §15 count of 39 (3 + 35 + CR).
"""


@dataclass(frozen=True)
class Step:
    """One frame sent to the controller and the reply the manual gives for it."""

    send: bytes
    reply: bytes | None
    wait_idle: bool = False
    control: str = ""
    """NEEDS_CONTROL only: control-surface action before sending, e.g. "force 1:cw_limit=on"."""


@dataclass(frozen=True)
class Example:
    """One example exchange of the manual: the steps in order and where it is printed."""

    section: str
    line: int
    steps: tuple[Step, ...]
    setup: str = ""
    note: str = ""
    needs: Mapping[str, str] = field(default_factory=dict)

    @property
    def bodies(self) -> str:
        """Body numbers the example talks to, in order of first use (e.g. "1" or "2")."""
        seen: list[str] = []
        for step in self.steps:
            if len(step.send) > 1 and chr(step.send[1]) not in seen:
                seen.append(chr(step.send[1]))
        return "".join(seen)

    @property
    def ident(self) -> str:
        """A short ASCII id for test reports: section and manual line, e.g. "10-OH@L5470"."""
        section = self.section.replace("§", "").replace(" ", "-").replace('""', "NULL")
        return f"{section}@L{self.line}"


def _ack(send: bytes, *, wait: bool = False, control: str = "") -> Step:
    """A general command answered by the bare `>`."""
    return Step(send, ACK, wait, control)


S = Step  # short alias: the tables below are long


# ---------------------------------------------------------------------------------------------
# Main table: runnable with commands alone in a fresh simulator (default scene).
# ---------------------------------------------------------------------------------------------

_CH8_9: tuple[Example, ...] = (
    Example(
        "§8-1",
        785,
        (S(b"$1\r", b">$10\r"),),
        setup="body 1, power just on",
        note="§8-1 (III): send [$1 CR]; the normal answer is [>$10] (no error, motor stopped).",
    ),
    Example(
        "§8-2",
        850,
        (
            _ack(b"$10\r"),
            S(b"$1\r", b">$11\r", wait_idle=True),
            S(b"$16\r", b">$100000000\r"),
        ),
        setup="default scene (ORG inside the stroke)",
        note="Line 843: $10 answers [>] and the motor stops on ORG. Line 850: >$11 = pulses "
        "being output (on a real rig a symptom; here the homing still runs). Step 3 added: "
        "the homed point is position 0 (§10 0 解説).",
    ),
    Example(
        "§8-2",
        874,
        (_ack(b"$1O\r"), S(b"$1\r", b">$18\r"), _ack(b"$10\r")),
        note="(3) >$18 = command error, caused by a typing mistake; then resend [$10]. The "
        "mistake is our choice: letter O instead of zero (no command 'O' alone).",
    ),
    Example(
        "§9-1",
        926,
        (_ack(b"$1O\r"), S(b"$19\r", b">$108\r"), S(b"$1\r", b">$18\r")),
        note='A malformed command is ignored and sets the command-error flag of both "" and '
        "9; the reply is still >. 'O' alone (letter) is our malformed command.",
    ),
    Example(
        "§9-1",
        927,
        (
            _ack(b"$17\r"),
            _ack(b"$18\r"),
            S(b"$1\r", b">$19\r"),
            _ack(b"$1S\r", wait=True),
            S(b"$19\r", b">$108\r"),
        ),
        setup="motor 1 free to jog CW for a moment",
        note="A motion command while the motor turns is ignored and sets command error "
        '("" 9 = moving + command error). S stops the jog; 9 still holds its own copy of '
        'the error although wait_idle has read "" (§10 9 注意点④).',
    ),
    Example(
        "§9-1",
        934,
        (
            _ack(b"$1F2\r"),
            _ack(b"$1OH3000\r"),
            _ack(b"$1F1\r"),
            S(b"$1OH\r", b">$105000\r"),
            _ack(b"$1F2\r"),
            S(b"$1OH\r", b">$103000\r"),
        ),
        note="Per-motor settings: same format, separate storage for motor 1 and 2; defaults "
        "identical (line 942). Constructed from the text; OH is in the §10 F per-motor list.",
    ),
    Example(
        "§9-1",
        946,
        (
            _ack(b"$1F2\r"),
            _ack(b"$1R\r"),
            _ack(b"$1F1\r"),
            _ack(b"$122000\r"),
            _ack(b"$132\r", wait=True),
            _ack(b"$14\r", wait=True),
            S(b"$162\r", b">$100004000\r"),
            S(b"$1F\r", b">$12\r"),
        ),
        setup="motor 2 has >= 4,000 pulses of free travel CW",
        note='The example frame is an image lost in OCR; the text names command "3 2" (motor '
        '2 to the position), then "4" without motor, which runs on motor 2. Steps 1-3 (zero '
        "motor 2), 7 and 8 added.",
    ),
)

_NULL_AND_9: tuple[Example, ...] = (
    Example(
        "§10 intro",
        1034,
        (_ack(b"$120200030\r"), _ack(b"$131\r")),
        note="§10 重要な注意事項: the example of command 3 sent back to back. The OCR prints "
        "'$120200030' (the §10 3 example itself is $122000): taken verbatim, it is command 2 "
        "with 0200030 (7 digits, 200,030), still answered >. The move may run into the CW "
        "limit of the scene; only the replies are checked.",
    ),
    Example('§10 ""', 1098, (S(b"$1\r", b">$10\r"),), note="応答例 (I): no error, stopped."),
    Example(
        '§10 ""',
        1107,
        (_ack(b"$27\r"), _ack(b"$28\r"), S(b"$2\r", b">$29\r"), _ack(b"$2S\r")),
        setup="body 2 present",
        note="応答例 (II) >$29: body 2, command error while moving (9 = 1001). The state is "
        "made by a second jog command while the first runs (§9-1 注意).",
    ),
    Example(
        '§10 ""',
        1127,
        (S(b"$2\r", b">$20\r"),),
        setup="body 2 present, power just on",
        note="使用例 $2: the reply is not printed; a fresh controller has no error, stopped.",
    ),
    Example(
        '§10 ""',
        1132,
        (_ack(b"$1O\r"), S(b"$1\r", b">$18\r"), S(b"$1\r", b">$10\r")),
        note="注意点: after the reply, bits 1-3 of the status flags are all cleared.",
    ),
    Example(
        '§10 ""',
        1135,
        (_ack(b"$1O\r"), S(b"$19\r", b">$108\r"), S(b"$1\r", b">$18\r")),
        note='注意点: 9 does not clear the status flags of "" (separate storage).',
    ),
    Example(
        "§10 9", 2522, (S(b"$19\r", b">$100\r"),), note="応答例 (I): no error, mode 0, motor 1."
    ),
    Example(
        "§10 9",
        2565,
        (S(b"$296\r", b">$20\r"),),
        setup="body 2 present, power just on",
        note="使用例 $296 asks the step-out bit; reply not printed: 0 on a fresh controller.",
    ),
    Example(
        "§10 9",
        2571,
        (
            _ack(b"$1O\r"),
            S(b"$193\r", b">$11\r"),
            S(b"$193\r", b">$11\r"),
            S(b"$19\r", b">$108\r"),
            S(b"$19\r", b">$100\r"),
        ),
        note="注意点① form (I) clears bits 0-3 after the reply; ② form (II) clears nothing.",
    ),
    Example(
        "§10 9",
        2577,
        (_ack(b"$1O\r"), S(b"$1\r", b">$18\r"), S(b"$19\r", b">$108\r")),
        note='注意点④ "" does not clear the condition flags of 9.',
    ),
    Example(
        "§10 9",
        2480,
        (
            _ack(b"$1F2\r"),
            S(b"$19\r", b">$180\r"),
            S(b"$197\r", b">$11\r"),
            S(b"$194\r", b">$10\r"),
            S(b"$195\r", b">$10\r"),
            S(b"$196\r", b">$10\r"),
        ),
        note="bit 7 = motor 2 selected; form (II) on bit 4 or 5 gives the mode number (0).",
    ),
)

_HOMING: tuple[Example, ...] = (
    Example(
        "§10 0",
        1193,
        (_ack(b"$10\r", wait=True), S(b"$16\r", b">$100000000\r")),
        setup="default scene (ORG inside the stroke)",
        note="使用例 $10. Step 2 added: the homed point is position 0 (解説 A-C).",
    ),
    Example(
        "§10 0",
        1180,
        (_ack(b"$102\r", wait=True), S(b"$162\r", b">$100000000\r"), S(b"$1F\r", b">$12\r")),
        setup="default scene",
        note="Form (II) with MT 2 (§15 '$B#02'); a motor suffix also selects that motor "
        "(§9-1, §10 F). Readbacks added.",
    ),
    Example(
        "§10 0A",
        1291,
        (_ack(b"$10A\r", wait=True), S(b"$16\r", b">$100000000\r")),
        setup="default scene",
        note="No 使用例; format (I) and its reply >. Readback added (解説: origin = 0).",
    ),
    Example(
        "§10 0B",
        1351,
        (
            S(b"$10B\r", b">$12\r"),
            _ack(b"$10B3\r"),
            S(b"$10B\r", b">$13\r"),
            _ack(b"$1F2\r"),
            S(b"$10B\r", b">$12\r"),
        ),
        note="Default 2; per motor (機能). The query reply image is lost; §15 gives 5 "
        "characters, i.e. one digit.",
    ),
    Example(
        "§10 0H",
        1396,
        (_ack(b"$10H\r", wait=True), S(b"$16\r", b">$100000000\r")),
        setup="default scene",
        note="No 使用例; format (I) and its reply >. Readback added.",
    ),
    Example(
        "§10 0R",
        1585,
        (_ack(b"$10R1\r", wait=True), S(b"$16\r", b">$100000000\r")),
        setup="default scene (ORG and CCW limit inside the stroke)",
        note="使用例 $10R1. Readback added.",
    ),
    Example(
        "§10 0S",
        1633,
        (S(b"$10S\r", b">$100020\r"),),
        note="Default 20; query reply 10進5桁 (§15 prints 7 characters: OCR, the §10 format "
        "with 5 digits wins).",
    ),
    Example(
        "§10 0S",
        1661,
        (
            _ack(b"$1F1\r"),
            _ack(b"$10S500\r"),
            _ack(b"$1F2\r"),
            _ack(b"$10S30\r"),
            S(b"$10S\r", b">$100030\r"),
            _ack(b"$1F1\r"),
            S(b"$10S\r", b">$100500\r"),
        ),
        note="使用例: 500 for motor 1, 30 for motor 2. Readbacks (steps 5-7) added.",
    ),
    Example(
        "§10 0Z",
        1849,
        (S(b"$10ZD\r", b">$11\r"), _ack(b"$10Z4\r"), S(b"$10ZD\r", b">$14\r")),
        note="Z count: default 1, form (II) sets, form (III) 0ZD queries (1 digit, §15: 5 "
        "characters). 4 is the count of the 解説 example.",
    ),
)

_MOTION: tuple[Example, ...] = (
    Example(
        "§10 1",
        1964,
        (_ack(b"$2R1000\r"), _ack(b"$21\r", wait=True), S(b"$26\r", b">$200000000\r")),
        setup="body 2 present; motor 1 has >= 1,000 pulses of free travel CCW",
        note="使用例 $21 (body 2, back to the origin at high speed). Steps 1 and 3 added.",
    ),
    Example(
        "§10 2",
        2009,
        (
            _ack(b"$123000\r"),
            S(b"$12D\r", b">$100003000\r"),
            _ack(b"$1R500\r"),
            _ack(b"$12\r"),
            S(b"$12D\r", b">$100000500\r"),
        ),
        note="使用例 $123000 and $12 (form II: current position). Query form (III) is an image "
        "lost in OCR; §15 gives '$B#2D' with 12 characters. Steps 2, 3, 5 added.",
    ),
    Example(
        "§10 2",
        2016,
        (
            _ack(b"$1R1000\r"),
            _ack(b"$17\r"),
            _ack(b"$12\r"),
            _ack(b"$1S\r", wait=True),
            S(b"$12D\r", b">$100001000\r"),
            S(b"$19\r", b">$100\r"),
        ),
        setup="motor 1 free to jog CW for a moment",
        note="注意点: form (II) while moving is no error and stores the start point of the move.",
    ),
    Example(
        "§10 3",
        2072,
        (
            _ack(b"$1R\r"),
            _ack(b"$122000\r"),
            _ack(b"$131\r", wait=True),
            S(b"$16\r", b">$100002000\r"),
        ),
        setup="motor 1 has >= 2,000 pulses of free travel CW",
        note="使用例 $122000, $131. Steps 1 and 4 added.",
    ),
    Example(
        "§10 4",
        2145,
        (
            _ack(b"$2R\r"),
            _ack(b"$223000\r"),
            _ack(b"$241\r", wait=True),
            S(b"$26\r", b">$200003000\r"),
        ),
        setup="body 2 present; its motor 1 has >= 3,000 pulses of free travel CW",
        note="使用例 $223000, $241 (body 2, motor 1, CW 3,000). Steps 1 and 4 added.",
    ),
    Example(
        "§10 5",
        2207,
        (
            _ack(b"$1R5000\r"),
            _ack(b"$122000\r"),
            _ack(b"$15\r", wait=True),
            S(b"$16\r", b">$100003000\r"),
        ),
        setup="motor 1 has >= 2,000 pulses of free travel CCW",
        note="使用例 $122000, $15 (CCW 2,000). Steps 1 and 4 added.",
    ),
    Example(
        "§10 6",
        2254,
        (_ack(b"$1R3500\r"), S(b"$16\r", b">$100003500\r"), S(b"$161\r", b">$100003500\r")),
        note="応答例 >$100003500 (position 3,500); R (step 1) makes that position; step 3 "
        "added (form II with MT 1).",
    ),
    Example(
        "§7-4",
        671,
        (
            _ack(b"$1R\r"),
            _ack(b"$122000\r"),
            _ack(b"$15\r", wait=True),
            S(b"$16\r", b">$116775216\r"),
            _ack(b"$1EP1\r"),
            S(b"$16\r", b">$1-0002000\r"),
        ),
        setup="motor 1 has >= 2,000 pulses of free travel CCW",
        note="Unsigned management: moving to -2000 gives 16,775,216. Steps 5-6 added: the same "
        "24-bit counter read signed (§10 EP table).",
    ),
    Example(
        "§10 7",
        2315,
        (
            _ack(b"$17\r"),
            S(b"$1\r", b">$11\r"),
            _ack(b"$1S\r"),
            S(b"$1\r", b">$10\r"),
        ),
        setup="motor 1 free to jog CW for a moment",
        note="使用例 $17; it runs until a limit or S/SS (注意点). Steps 2-4 added.",
    ),
    Example(
        "§10 7*",
        2327,
        (_ack(b"$1R100\r"), _ack(b"$17*\r", wait=True), S(b"$16\r", b">$100000101\r")),
        note="No 使用例: one pulse CW (CW counts up: §10 3 注意点).",
    ),
    Example(
        "§10 8",
        2390,
        (
            _ack(b"$18\r"),
            S(b"$1\r", b">$11\r"),
            _ack(b"$1S\r"),
            S(b"$1\r", b">$10\r"),
        ),
        setup="motor 1 free to jog CCW for a moment",
        note="使用例 $18. Steps 2-4 added.",
    ),
    Example(
        "§10 8*",
        2402,
        (_ack(b"$1R100\r"), _ack(b"$18*\r", wait=True), S(b"$16\r", b">$100000099\r")),
        note="No 使用例: one pulse CCW.",
    ),
    Example(
        "§10 H",
        4788,
        (_ack(b"$17\r"), _ack(b"$1H\r"), _ack(b"$1L\r"), _ack(b"$1S\r")),
        setup="motor 1 free to jog CW for a moment",
        note="H and L change the speed of a 7/8 jog; replies > (§10 H, L formats).",
    ),
    Example(
        "§10 S",
        6658,
        (_ack(b"$17\r"), _ack(b"$1S\r"), S(b"$1\r", b">$10\r")),
        setup="motor 1 free to jog CW for a moment",
        note='No 使用例: S stops at once, so the next "" shows stopped.',
    ),
    Example(
        "§10 SS",
        6674,
        (_ack(b"$17\r"), _ack(b"$1SS\r"), S(b"$1\r", b">$10\r")),
        setup="motor 1 free to jog CW for a moment",
        note="No 使用例: SS goes to low speed, then stops; a 7 jog already runs at low speed, "
        "so it stops at once (the CLR list of §10 DS ⑤ treats SS at low speed like S).",
    ),
)

_POSITIONS: tuple[Example, ...] = (
    Example(
        "§10 A",
        2655,
        (_ack(b"$1A0023000\r"), S(b"$1A002D\r", b">$100003000\r")),
        note="使用例 $1A0023000. Readback added ('$B#A□□□D', §15, 12 characters).",
    ),
    Example(
        "§10 A",
        2657,
        (_ack(b"$1R7000\r"), _ack(b"$1A022\r"), S(b"$1A022D\r", b">$100007000\r")),
        note="使用例 $1A022 (the text says 'position number 02'; the frame has 022, 3 digits "
        "as required). Steps 1 and 3 added.",
    ),
    Example(
        "§10 A",
        2606,
        (_ack(b"$1A0051234\r"), _ack(b"$1F2\r"), S(b"$1A005D\r", b">$100001234\r")),
        note="A is shared by motors 1 and 2 (共用データ).",
    ),
    Example(
        "§10 AL",
        2684,
        (_ack(b"$1A0051234\r"), _ack(b"$1AL\r"), S(b"$1A005D\r", b">$100000000\r")),
        note="AL with no AW ever done copies the factory values (0) into RAM.",
    ),
    Example(
        "§10 B",
        2775,
        (
            _ack(b"$1R\r"),
            _ack(b"$1A1001000\r"),
            _ack(b"$1A1012000\r"),
            _ack(b"$1A1023000\r"),
            _ack(b"$1B100\r", wait=True),
            _ack(b"$1B\r", wait=True),
            _ack(b"$1B\r", wait=True),
            S(b"$1BN\r", b">$100103\r"),
            S(b"$16\r", b">$100003000\r"),
        ),
        setup="motor 1 has >= 3,000 pulses of free travel CW",
        note="解説 ①-④: B100, B, B, BN -> >$100103 (next number 103, 5 digits). Steps 1-4 "
        "(positions 1000/2000/3000) and 9 added.",
    ),
    Example(
        "§10 B",
        2760,
        (S(b"$1BN\r", b">$100000\r"),),
        note="BN at power-on: 【初期値 = 00000】, 5 digits (§15 prints 3 digits / 7 "
        "characters; the §10 example >$100103 wins).",
    ),
    Example(
        "§10 B",
        2796,
        (_ack(b"$1R3000\r"), _ack(b"$1B005\r", wait=True), S(b"$16\r", b">$100000000\r")),
        setup="motor 1 has >= 3,000 pulses of free travel CCW",
        note="使用例 $1B005; A005 was never set, so B goes to the origin (注意点, line 2801).",
    ),
    Example(
        "§10 B",
        2803,
        (
            _ack(b"$1R\r"),
            _ack(b"$1A0011500\r"),
            _ack(b"$1B\r", wait=True),
            S(b"$16\r", b">$100001500\r"),
            S(b"$1BN\r", b">$100002\r"),
        ),
        setup="motor 1 has >= 1,500 pulses of free travel CW",
        note="注意点: form (III) before any B/B+(-) goes to position number 001.",
    ),
    Example(
        "§10 B+(-)",
        2851,
        (
            _ack(b"$1R\r"),
            _ack(b"$1A0201000\r"),
            _ack(b"$1A021400\r"),
            _ack(b"$1A022200\r"),
            _ack(b"$1B020+\r", wait=True),
            _ack(b"$1B-\r", wait=True),
            _ack(b"$1B+\r", wait=True),
            S(b"$16\r", b">$100000800\r"),
            S(b"$1BN\r", b">$100023\r"),
        ),
        setup="motor 1 has >= 1,000 pulses of free travel CW",
        note="解説 ①-③: B020+, B-, B+ (numbers 020, 021, 022). Steps 1-4 (1000/400/200), 8 and "
        "9 added: 0 +1000 -400 +200 = 800; BN shows the next number (B and B+(-) share it).",
    ),
    Example(
        "§10 B+(-)",
        2863,
        (_ack(b"$1B0112+\r"), S(b"$1F\r", b">$12\r")),
        note="使用例 $1B0112+ (motor 2, CW by A011). A011 is 0, so no motion (注意点). Step 2 "
        "added: a motor suffix selects that motor.",
    ),
    Example(
        "§10 B+(-)",
        2868,
        (_ack(b"$1R3000\r"), _ack(b"$1B500+\r", wait=True), S(b"$16\r", b">$100003000\r")),
        note="注意点: an unset position number (0) gives no motion.",
    ),
    Example(
        "§10 B+(-)",
        2871,
        (
            _ack(b"$1EP1\r"),
            _ack(b"$1A001-5000\r"),
            _ack(b"$1R\r"),
            _ack(b"$1B001+\r", wait=True),
            S(b"$16\r", b">$1+0005000\r"),
            _ack(b"$1B001-\r", wait=True),
            S(b"$16\r", b">$1+0000000\r"),
        ),
        setup="motor 1 has >= 5,000 pulses of free travel CW",
        note="注意点: B+(-) moves by the absolute value: A001 = -5000, B001+ goes CW 5,000 and "
        "B001- back. EP1 makes the negative value settable and the replies signed.",
    ),
    Example(
        "§10 R",
        6600,
        (
            _ack(b"$1R8000\r"),
            S(b"$16\r", b">$100008000\r"),
            _ack(b"$1R\r"),
            S(b"$16\r", b">$100000000\r"),
        ),
        note="使用例 $1R8000 (line 6626), then form (I): the current point becomes 0. Readbacks "
        "added.",
    ),
)

_SETTINGS: tuple[Example, ...] = (
    Example(
        "§10 EA",
        3695,
        (
            S(b"$1EA\r", b">$100\r"),
            _ack(b"$1EA08\r"),
            S(b"$1EA\r", b">$108\r"),
            _ack(b"$1F2\r"),
            S(b"$1EA\r", b">$100\r"),
        ),
        note="Default 00; form (I) sets the selected motor's logic (bit 3 = ORG as B contact); "
        "per motor. The format images are lost; §15 '$B#EA□□' and a 6-character query.",
    ),
    Example(
        "§10 ED",
        3807,
        (S(b"$1ED\r", b">$11\r"), _ack(b"$1ED0\r"), S(b"$1ED\r", b">$10\r")),
        note="Default 1 (2P); ED0 = PULSE&DIR; query DT 0/1 (§15 5 characters).",
    ),
    Example("§10 ES", 4256, (S(b"$1ES\r", b">$10\r"),), note="Default 0 = 9,600 bps."),
    Example("§10 F", 4338, (S(b"$1F\r", b">$11\r"),), note="Default motor 1."),
    Example(
        "§10 F",
        4358,
        (
            _ack(b"$1F2\r"),
            _ack(b"$1R\r"),
            _ack(b"$1F1\r"),
            _ack(b"$121000\r"),
            _ack(b"$142\r", wait=True),
            S(b"$1F\r", b">$12\r"),
            S(b"$16\r", b">$100001000\r"),
        ),
        setup="motor 2 has >= 1,000 pulses of free travel CW",
        note="例) image lost; the text: motor 2 with command 4, the same as F2 then 4, so the "
        "selection stays on motor 2 (line 4360). Reconstructed as $142; the rest added.",
    ),
    Example(
        "§10 F",
        4374,
        (
            _ack(b"$1F2\r"),
            _ack(b"$1R2000\r"),
            _ack(b"$1F1\r"),
            S(b"$162\r", b">$100002000\r"),
            S(b"$1F\r", b">$11\r"),
        ),
        note="6{MT} asks a motor's position without changing the selection.",
    ),
    Example(
        "§10 F",
        4384,
        (
            _ack(b"$1F1\r"),
            _ack(b"$10\r", wait=True),
            _ack(b"$1F2\r"),
            _ack(b"$10\r", wait=True),
            S(b"$161\r", b">$100000000\r"),
            S(b"$162\r", b">$100000000\r"),
        ),
        setup="default scene, both motors with ORG inside the stroke",
        note='使用例: home motor 1, then motor 2; the manual inserts the "" polling loop '
        "before F2 (wait_idle). Readbacks added.",
    ),
    Example(
        "§10 F",
        4391,
        (
            _ack(b"$17\r"),
            _ack(b"$1F2\r"),
            _ack(b"$1S\r", wait=True),
            S(b"$1F\r", b">$11\r"),
            S(b"$19\r", b">$108\r"),
        ),
        setup="motor 1 free to jog CW for a moment",
        note="F cannot be executed while a motor moves (line 4391; table 動作中 ×). Our "
        "reading: ignored with a command error, like a format error (§9-1).",
    ),
    Example(
        "§10 N",
        5290,
        (
            _ack(b"$1R\r"),
            _ack(b"$1A00125000\r"),
            _ack(b"$1NC\r"),
            _ack(b"$1N18000,20000\r"),
            _ack(b"$1N24000,10000\r"),
            _ack(b"$1N32000,5000\r"),
            _ack(b"$1NS\r"),
            S(b"$1N\r", b">$11\r"),
            _ack(b"$1B001+\r", wait=True),
            S(b"$1N\r", b">$10\r"),
            _ack(b"$1NS\r"),
            _ack(b"$1B001-\r", wait=True),
            S(b"$16\r", b">$100000000\r"),
        ),
        setup="motor 1 has >= 25,000 pulses of free travel CW",
        note="使用例 (round trip CW then CCW). The OCR prints the last frame as '$1B0012' (motor "
        "2, absolute) against the text 'CW方向移動とCCW方向移動の往復運転': reconstructed as "
        "$1B001-. The manual omits the wait between the moves (NS is × while moving). Steps "
        "1, 8, 10, 13 added: NS is on until one move has used it (line 5270).",
    ),
    Example("§10 N", 5149, (S(b"$1N\r", b">$10\r"),), note="§16: N off at power-on."),
    Example(
        "§10 OC",
        5369,
        (S(b"$1OC\r", b">$1000\r"), _ack(b"$1OC50\r"), S(b"$1OC\r", b">$1050\r")),
        note="Default 0; query 10進数3桁.",
    ),
    Example(
        "§10 OC",
        5435,
        (
            _ack(b"$1OH9000\r"),
            _ack(b"$1OC100\r"),
            S(b"$1OC\r", b">$1000\r"),
            S(b"$1\r", b">$18\r"),
        ),
        note="重要な注意事項: (9000-500)/(2*(200-100))*100 = 4250 > 4095 -> command error, OC "
        "unchanged.",
    ),
    Example(
        "§10 OH",
        5534,
        (
            _ack(b"$1OC100\r"),
            _ack(b"$1OH16000\r"),
            S(b"$1OH\r", b">$105000\r"),
            S(b"$1\r", b">$18\r"),
        ),
        note="重要な注意事項: (16000-500)/200*100 = 7750 > 4095 -> command error, OH unchanged "
        "(OC 100 itself: 4500/200*100 = 2250, allowed).",
    ),
    Example(
        "§10 OH",
        5499,
        (
            S(b"$1OH\r", b">$105000\r"),
            _ack(b"$1OHI100\r"),
            S(b"$1OH\r", b">$105100\r"),
            _ack(b"$1OHD200\r"),
            S(b"$1OH\r", b">$104900\r"),
        ),
        note="Default 5000; forms (III) increment and (IV) decrement; query 10進数5桁.",
    ),
    Example(
        "§10 OL",
        5615,
        (
            _ack(b"$1OH9000\r"),
            _ack(b"$1OL1000\r"),
            _ack(b"$1OC100\r"),
            _ack(b"$1OL500\r"),
            S(b"$1OL\r", b">$101000\r"),
            S(b"$1\r", b">$18\r"),
        ),
        note="重要な注意事項: OH 9000 OL 1000 OC 100 gives 4000 (allowed); OL 500 would give "
        "4250 > 4095 -> command error, OL unchanged.",
    ),
    Example(
        "§10 OL",
        5587,
        (
            S(b"$1OL\r", b">$100500\r"),
            _ack(b"$1OLI100\r"),
            S(b"$1OL\r", b">$100600\r"),
            _ack(b"$1OLD300\r"),
            S(b"$1OL\r", b">$100300\r"),
        ),
        note="Default 500; forms (III)/(IV).",
    ),
    Example(
        "§10 OS",
        5728,
        (
            S(b"$1OS\r", b">$100300\r"),
            _ack(b"$1OSI32500\r"),
            S(b"$1OS\r", b">$100300\r"),
            S(b"$1\r", b">$18\r"),
            _ack(b"$1OSD300\r"),
            S(b"$1OS\r", b">$100300\r"),
            S(b"$1\r", b">$18\r"),
        ),
        note="注意点: OSI past 32,767 and OSD to 0 or below are command errors, value unchanged.",
    ),
    Example(
        "§10 OX",
        5739,
        (
            S(b"$1OX\r", b">$100300\r"),
            _ack(b"$1F2\r"),
            _ack(b"$1OX600\r"),
            _ack(b"$1F1\r"),
            S(b"$1OX\r", b">$100600\r"),
        ),
        note="Default 300; OX is shared by both motors (共通データ).",
    ),
    Example(
        "§10 R",
        4354,
        (
            _ack(b"$1F2\r"),
            _ack(b"$1R8000\r"),
            _ack(b"$1F1\r"),
            _ack(b"$1R\r"),
            S(b"$162\r", b">$100008000\r"),
            S(b"$161\r", b">$100000000\r"),
        ),
        note="R is in the §10 F list of per-motor commands: it presets the selected motor only.",
    ),
    Example(
        "§10 V",
        6870,
        (S(b"$1V\r", None),),
        note="The version is not given (×.××); test_manual_examples checks the shape against "
        "VERSION_REPLY_PATTERN instead.",
    ),
)

_EE: tuple[Example, ...] = (
    Example(
        "§10 EE",
        3924,
        (
            S(b"$1EE\r", b">$10\r"),
            _ack(b"$1EE1\r"),
            S(b"$1EE\r", b"$1EE\r$11\r"),
            S(b"$1EE0\r", b"$1EE0\r"),
            S(b"$1EE\r", b">$10\r"),
            _ack(b"$1EE0\r"),
        ),
        note="Formats: EE1 -> >; EE0 while on -> its echo $1EE0 CR; EE0 when already off -> "
        "> (line 3951); query on -> echo + $11 CR (§15: 9 characters), off -> >$10 CR.",
    ),
    Example(
        "§10 EE",
        4021,
        (_ack(b"$1EE1\r"), S(b"$1\r", b"$1\r$10\r")),
        note="Table row 1, echo ON: echo part (the frame as received) + reply without '>'.",
    ),
    Example(
        "§10 EE",
        4022,
        (_ack(b"$1EE1\r"), S(b"$10\r", b"$10\r")),
        setup="default scene (the homing starts; not waited for)",
        note="Table row 2: a general command's reply is only the echo.",
    ),
    Example(
        "§10 EE",
        4023,
        (_ack(b"$1R300\r"), _ack(b"$1EE1\r"), S(b"$16\r", b"$16\r$100000300\r")),
        note="Table row 3: position 300 (made with R, added).",
    ),
    Example(
        "§10 EE",
        4024,
        (_ack(b"$1EE1\r"), S(b"$1B01\r", b"$1B01\r")),
        note="Table row 4. '$1B01' has a 2-digit position number (B needs 3): a command error "
        "either way, and its reply is only the echo. Kept verbatim.",
    ),
    Example(
        "§10 EE",
        4020,
        (
            _ack(b"$1R300\r"),
            S(b"$1\r", b">$10\r"),
            S(b"$16\r", b">$100000300\r"),
            _ack(b"$1B01\r"),
            _ack(b"$10\r"),
        ),
        setup="default scene (the homing starts; not waited for)",
        note="Table, OFF column, rows in an order that keeps them independent.",
    ),
)

_EL: tuple[Example, ...] = (
    Example(
        "§10 EL",
        4101,
        (
            S(b"$1EL\r", b">$10\r"),
            S(b"$1EL1\r", b">\r"),
            S(b"$1EL\r", b">$11\r"),
            _ack(b"$1EL0\r"),
            S(b"$1EL\r", b">$10\r"),
        ),
        note="Formats: EL1 -> > CR; EL0 -> >; query DC 0/1.",
    ),
    Example("§10 EL", 4128, (S(b"$1EL1\r", b">\r"), S(b"$10\r", b">\r")), setup="default scene"),
    Example("§10 EL", 4129, (S(b"$1EL1\r", b">\r"), S(b"$1\r", b">$10\r"))),
    Example(
        "§10 EL",
        4130,
        (S(b"$1EL1\r", b">\r"), S(b"$1B01\r", b">\r")),
        note="'$1B01' verbatim (command error; reply still > CR).",
    ),
    Example(
        "§10 EL",
        4131,
        (_ack(b"$1R300\r"), S(b"$1EL1\r", b">\r"), S(b"$16\r", b">$100000300\r")),
        note="OCR prints '>100000300' without '$'; query replies do not change with EL "
        "(format I), so reconstructed as >$100000300. Step 1 added.",
    ),
)

_EP: tuple[Example, ...] = (
    Example("§10 EP", 4151, (S(b"$1EP\r", b">$10\r"),), note="Default 0 (unsigned)."),
    Example(
        "§10 EP",
        4169,
        (
            _ack(b"$1R0\r"),
            S(b"$16\r", b">$100000000\r"),
            _ack(b"$1EP1\r"),
            S(b"$1EP\r", b">$11\r"),
            S(b"$16\r", b">$1+0000000\r"),
        ),
        note="Row 1. OCR '+00000000' (8 digits) reconstructed as sign + 7 digits.",
    ),
    Example(
        "§10 EP",
        4170,
        (
            _ack(b"$1R8388607\r"),
            S(b"$16\r", b">$108388607\r"),
            _ack(b"$1EP1\r"),
            S(b"$16\r", b">$1+8388607\r"),
        ),
        note="Row 2. OCR '-8388607' in the signed column: the two columns of rows 2 and 3 are "
        "swapped in sign; 24-bit two's complement (as row 4) gives +8388607.",
    ),
    Example(
        "§10 EP",
        4171,
        (
            _ack(b"$1R8388608\r"),
            S(b"$16\r", b">$108388608\r"),
            _ack(b"$1EP1\r"),
            S(b"$16\r", b">$1-8388608\r"),
        ),
        note="Row 3. OCR '+8388608' reconstructed as -8388608 (24-bit two's complement).",
    ),
    Example(
        "§10 EP",
        4172,
        (
            _ack(b"$1R16777215\r"),
            S(b"$16\r", b">$116777215\r"),
            _ack(b"$1EP1\r"),
            S(b"$16\r", b">$1-0000001\r"),
        ),
        note="Row 4, as printed.",
    ),
)

_ER: tuple[Example, ...] = (
    Example(
        "§10 ER",
        4219,
        (
            S(b"$1ER\r", b">$10\r"),
            _ack(b"$1ER1\r"),
            S(b"$1ER\r", b">$11\r"),
            S(b"$1O\r", b">@"),
            S(b"$1\r", b">$18\r"),
            S(b"$19\r", b">$108\r"),
            S(b"$1OH\r", b">$105000\r"),
            _ack(b"$1ER0\r"),
            _ack(b"$1O\r"),
        ),
        note='>@ only for the command in error, no CR (line 4221); the flags of "" and 9 are '
        "set as usual (line 4220); good commands keep their normal reply.",
    ),
    Example(
        "§10 ER",
        4221,
        (_ack(b"$1ER1\r"), S(b"$1EL1\r", b">\r"), S(b"$1O\r", b">@\r")),
        note="'[CR] を追加したいときは、コマンド \"EL\" を設定': with EL1 the error reply is "
        ">@ CR (our reading).",
    ),
    Example(
        "§10 ER",
        4191,
        (_ack(b"$1ER1\r"), _ack(b"$17\r"), S(b"$18\r", b">@"), _ack(b"$1S\r")),
        setup="motor 1 free to jog CW for a moment",
        note="A motion command while moving is a command error (§9-1), so it gets >@.",
    ),
)

_SUM: tuple[Example, ...] = (
    Example(
        "§10 SUM",
        6711,
        (
            S(b"$1SUM\r", b">$10\r"),
            _ack(b"$1SUM1\r"),
            S(b"$1SUM4A\r", b">$11C4\r"),
            _ack(b"$1SUM07A\r"),
            S(b"$1SUM\r", b">$10\r"),
        ),
        note="Query off -> >$10 (5 characters); on -> >$11C4 ('B# が 1 のとき ASCII は C4', "
        "line 6709; §15 7 characters). $1SUM = 330 = 14Ah -> 4A; $1SUM0 -> 17Ah -> 7A. "
        "SUM1/SUM0 answers > (images lost; a reply without CR stays '>' when the sum is OK).",
    ),
    Example(
        "§10 SUM",
        6738,
        (_ack(b"$1SUM1\r"), S(b"$155\r", b">$10C3\r")),
        note="Send table row 1 with reply table row 1 (line 6772): >$10 = 195 = C3h.",
    ),
    Example(
        "§10 SUM",
        6739,
        (_ack(b"$1R\r"), _ack(b"$1SUM1\r"), S(b"$168B\r", b">$10000000013\r")),
        note="Send table row 2. Reply derived: >$100000000 = 531 = 213h -> 13. Step 1 added.",
    ),
    Example(
        "§10 SUM",
        6740,
        (
            _ack(b"$1A0135000\r"),
            _ack(b"$1SUM1\r"),
            _ack(b"$1A013008A\r"),
            S(b"$1A013D6E\r", b">$10000000013\r"),
        ),
        note="Send table row 3: 'A01300' is A, position number 013, value 00 (= 0). Steps 1 "
        "(A013 = 5000 first, so the change shows) and 4 added: $1A013D = 366h -> 6E; reply "
        ">$100000000 = 531 = 213h -> 13.",
    ),
    Example(
        "§10 SUM",
        6774,
        (_ack(b"$1SUM1\r"), _ack(b"$1OA4\r"), S(b"$198E\r", b">$108FB\r")),
        note="Reply table row 3 >$108FB: a 9 reply with command error (08). Made with a "
        "malformed command ('$1O' + sum A4) and '$19' + sum 8E.",
    ),
    Example(
        "§10 SUM",
        6750,
        (
            _ack(b"$1SUM1\r"),
            S(b"$1R123472\r", b"?"),
            S(b"$1R123471\r", b">"),
        ),
        note="A reply without CR: one character = sum NG, another = sum OK; both are images "
        "lost in OCR. Reconstructed as '?' (NG, §9-2) and '>' (OK). $1R1234 sums to 171h -> 71; "
        "72 is wrong.",
    ),
    Example(
        "§10 SUM",
        6748,
        (_ack(b"$1SUM1\r"), S(b"$1EL117\r", b">3E\r"), S(b"$155\r", b">$10C3\r")),
        note="With EL1 a bare > becomes a CR reply, so it carries a sum: '>' = 3Eh. $1EL1 = "
        "117h -> 17. (SUM1 is sent first so its own reply is the plain '>'.)",
    ),
)

_DEFAULTS: tuple[Example, ...] = (
    Example(
        "§16",
        9360,
        (S(b"$12D\r", b">$100000000\r"),),
        note="Command 2 position data default 0 (12 characters, §15 '$B#2D').",
    ),
    Example(
        "§16",
        9361,
        (S(b"$1A000D\r", b">$100000000\r"), S(b"$1A999D\r", b">$100000000\r")),
        note="A (all 1000 points) default 0.",
    ),
    Example("§16", 9363, (S(b"$1E\r", b">$10\r"),), note="E mode default 0 (§15: 5 chars)."),
    Example("§16", 9366, (S(b"$1EE\r", b">$10\r"),), note="EE default 0."),
    Example("§16", 9367, (S(b"$1EL\r", b">$10\r"),), note="EL default 0."),
    Example("§16", 9369, (S(b"$1ER\r", b">$10\r"),), note="ER default 0."),
    Example("§16", 9375, (S(b"$1OC\r", b">$1000\r"),), note="OC default 0 (3 digits)."),
    Example(
        "§16",
        9376,
        (S(b"$1OH\r", b">$105000\r"), _ack(b"$1F2\r"), S(b"$1OH\r", b">$105000\r")),
        note="OH default 5000, the same for both motors.",
    ),
    Example("§16", 9377, (S(b"$1OL\r", b">$100500\r"),), note="OL default 500."),
    Example("§16", 9378, (S(b"$1OS\r", b">$100300\r"),), note="OS default 300."),
    Example("§16", 9379, (S(b"$1OX\r", b">$100300\r"),), note="OX default 300."),
    Example("§16", 9390, (S(b"$1SUM\r", b">$10\r"),), note="SUM default 0."),
)

_MODES_AND_IO: tuple[Example, ...] = (
    Example(
        "§10 9",
        2554,
        (_ack(b"$1E2\r"), S(b"$194\r", b">$12\r")),
        note="使用例 $194 -> >$12: mode 2.",
    ),
    Example(
        "§10 D",
        3407,
        (_ack(b"$1DE1\r"), S(b"$1CO\r", b">$1E1\r")),
        note="使用例 $1DE1: bits 0, 5-7 ON. Readback with CO added.",
    ),
    Example(
        "§10 E",
        3666,
        (_ack(b"$1E1\r"), S(b"$1E\r", b">$11\r"), S(b"$19\r", b">$110\r")),
        note="使用例 $1E1 (mode 1). Readbacks added (9 bits 5,4 = 01).",
    ),
    Example(
        "§10 K",
        5063,
        (_ack(b"$1K2,FF\r"), S(b"$1K\r", b">$12,FF\r")),
        note="使用例 $1K2, FF (the OCR shows a space after the comma; the format has none).",
    ),
    Example(
        "§10 K",
        5065,
        (_ack(b"$1K5,3\r"), S(b"$1K\r", b">$15,08\r")),
        note="使用例 $1K5, 3 (bit 3). Readback (DU DL of bit 3 = 08) is our reading.",
    ),
    Example("§10 P", 5849, (_ack(b"$1P2300\r"),), note="使用例: bit 2 ON for 30 s."),
    Example(
        "§10 QS",
        6547,
        (_ack(b"$1QS10\r"), S(b"$1QS\r", b">$110\r")),
        note="使用例 $1QS10; the text says 'motor 1 only' but the format is M2 M1, so '10' "
        "sets motor 2: an inconsistency of the manual, kept verbatim (readback as sent).",
    ),
    Example(
        "§10 T",
        6826,
        (_ack(b"$1T*10\r"), S(b"$1T\r", b">$11\r")),
        note="使用例: timer 1 s without the $1T message; T answers >$11 while counting, >$10 "
        "after (5 characters).",
    ),
    Example("§16", 9356, (S(b"$10QD\r", b">$100010\r"),), note="0Q pd default 10."),
    Example("§16", 9362, (S(b"$1CO\r", b">$100\r"),), note="D outputs default 00."),
    Example("§16", 9372, (S(b"$1GA\r", b">$10\r"),), note="GA default off."),
    Example("§16", 9373, (S(b"$1K\r", b">$10,00\r"),), note="K default 0,00."),
    Example("§16", 9382, (S(b"$1QD\r", b">$100400\r"),), note="Q default 400."),
    Example("§16", 9383, (S(b"$1QE\r", b">$14\r"),), note="QE default 4."),
    Example("§16", 9388, (S(b"$1QS\r", b">$100\r"),), note="QS default 00."),
    Example("§16", 9389, (S(b"$1QSE\r", b">$100\r"),), note="QSE default 00."),
    Example(
        "§16",
        9380,
        (_ack(b"$1E1\r"), S(b"$1PA\r", b">$11\r"), S(b"$1PB\r", b">$1010\r")),
        note="PA 1, PB 10 (mode 1 only commands; PB query 3 digits).",
    ),
    Example(
        "§16",
        9384,
        (
            _ack(b"$1E1\r"),
            S(b"$1QJ\r", b">$100\r"),
            S(b"$1QJA\r", b">$100800\r"),
            S(b"$1QJO\r", b">$100000\r"),
            S(b"$1QJT\r", b">$1003\r"),
        ),
        note="QJ 00, QJA 800, QJO 0, QJT 3 (mode 1; QJT 3 digits, QJA/QJO 5 digits).",
    ),
    Example(
        "§16",
        9358,
        (_ack(b"$1E2\r"), S(b"$10X\r", b">$10\r")),
        note="0X default 0 (mode 2 only).",
    ),
)

EXAMPLES: tuple[Example, ...] = (
    _CH8_9
    + _NULL_AND_9
    + _HOMING
    + _MOTION
    + _POSITIONS
    + _SETTINGS
    + _EE
    + _EL
    + _EP
    + _ER
    + _SUM
    + _DEFAULTS
    + _MODES_AND_IO
)
"""The main table: each runs in a fresh simulator with commands alone."""


# ---------------------------------------------------------------------------------------------
# Needs the control surface (sensor forcing, EMS, noise, power cycle, baud, unsolicited bytes).
# ---------------------------------------------------------------------------------------------

NEEDS_CONTROL: tuple[Example, ...] = (
    Example(
        "§8-2",
        864,
        (_ack(b"$17\r", control="force 1:cw_limit=on"), S(b"$1\r", b">$12\r")),
        setup="CW limit of motor 1 forced ON",
        note="(2) >$12: a limit sensor is ON, the motor stopped. A move starting into an ON "
        "limit stops at once with limit error.",
        needs={"sensor": "motor 1 cw_limit ON"},
    ),
    Example(
        '§10 ""',
        1116,
        (
            _ack(b"$17\r", control="force 1:cw_limit=on"),
            _ack(b"$1O\r"),
            S(b"$1\r", b">$1A\r"),
        ),
        setup="CW limit of motor 1 forced ON",
        note="応答例 (III) >$1A: command error and limit error, stopped.",
        needs={"sensor": "motor 1 cw_limit ON"},
    ),
    Example(
        "§9-2",
        988,
        (
            S(b"$1\r", b"?", control="noise"),
            S(b"$1\r", b">$10\r"),
            S(b"$19\r", b">$101\r"),
        ),
        setup="noise on the line before the frame (PC switched on/off)",
        note="参考: after noise a valid command may be answered ?; resend until a normal reply. "
        "Step 3 (bit 0 = communication error) is our reading of §10 9 bit 0.",
        needs={"fault": "one frame taken as noise (nak)"},
    ),
    Example(
        "§10 0",
        1232,
        (_ack(b"$10\r", wait=True), S(b"$19\r", b">$102\r")),
        setup="scene without an ORG sensor on motor 1",
        note="注意点: without ORG the search runs until the CW limit turns ON (a limit error; "
        'read through 9 because wait_idle reads "").',
        needs={"scene": "motor 1 ORG not connected"},
    ),
    Example(
        "§10 0Z",
        1859,
        (_ack(b"$10Z\r", wait=True), S(b"$16\r", b">$100000000\r")),
        setup="scene with the Z-phase (EZ) input of motor 1 connected",
        note="No 使用例; format (I) and >. Origin = 0 (解説).",
        needs={"scene": "motor 1 EZ connected"},
    ),
    Example(
        "§10 CL",
        3224,
        (
            S(
                b"$1CL\r",
                b">$121\r",
                control="force 1:cw_limit=on; force 1:org=off; force 1:ez=off; ems press",
            ),
        ),
        setup="CW limit of motor 1 ON and EMS ON, everything else OFF (the default scene may "
        "hold the step-out sensor ON, so it is forced OFF)",
        note="応答例 image lost; text: CWLS (bit 0) and EMS (bit 5) ON, 'HEX データ 21'.",
        needs={
            "sensor": "motor 1 cw_limit ON, org and ez (step-out sensor) OFF",
            "ems": "pressed",
        },
    ),
    Example(
        "§10 CL",
        3234,
        (S(b"$1CL4\r", b">$10\r", control="force 1:org=off"),),
        setup="motor 1 ORG OFF",
        note="応答例 image lost; text: DT is 0, ORG OFF.",
        needs={"sensor": "motor 1 org OFF"},
    ),
    Example(
        '§10 ""',
        1084,
        (
            _ack(b"$17\r"),
            S(b"$1\r", b">$14\r", control="ems press"),
            S(b"$19\r", b">$104\r"),
        ),
        setup="EMS pressed while motor 1 jogs",
        note="bit 2: EMS input was ON (the motor stops).",
        needs={"ems": "pressed during a jog"},
    ),
    Example(
        "§10 AW",
        2707,
        (
            _ack(b"$1A0051234\r"),
            _ack(b"$1AW\r"),
            S(b"", b"$1*\r"),
            S(b"$1A005D\r", b">$100001234\r", control="power_cycle"),
        ),
        note="> on receipt, $1* CR when the EEPROM write ends; after power-on AL runs by itself.",
        needs={"unsolicited": "$1*", "power": "cycle"},
    ),
    Example(
        "§10 DW",
        3572,
        (
            _ack(b"$1OH3000\r"),
            _ack(b"$1DW\r"),
            S(b"", b"$1*\r"),
            S(b"$1OH\r", b">$103000\r", control="power_cycle"),
            _ack(b"$1OH5000\r"),
            _ack(b"$1DL\r"),
            S(b"$1OH\r", b">$103000\r"),
        ),
        note="DW: > then $1* CR; DL (automatic at power-on) reloads the written values.",
        needs={"unsolicited": "$1*", "power": "cycle"},
    ),
    Example(
        "§10 EE///",
        4047,
        (
            _ack(b"$1OH3000\r"),
            _ack(b"$1DW\r"),
            S(b"", b"$1*\r"),
            _ack(b"$1EE///\r"),
            S(b"$1\r", b""),
            S(b"", b"$1*\r"),
            S(b"$1OH\r", b">$103000\r"),
            S(b"$1OH\r", b">$105000\r", control="power_cycle"),
        ),
        note="> then $1* CR after 10-20 s; commands meanwhile are ignored with no reply. The "
        "erase does not touch RAM (OH still 3000) but the next power-on has factory values.",
        needs={"unsolicited": "$1*", "power": "cycle", "time": "10-20 s erase"},
    ),
    Example(
        "§10 ES",
        4311,
        (_ack(b"$1ES1\r"), S(b"$1ES\r", b">$11\r", control="loop baud 1200")),
        note="使用例 $1ES1: 1,200 bps from right after the command (注意点). Whether its own > "
        "goes out at 9,600 is not said: we expect 9,600 (the reply to the frame received).",
        needs={"baud": "switch the loop to 1200 after step 1"},
    ),
    Example(
        "§10 9",
        2538,
        (
            _ack(b"$1E1\r"),
            _ack(b"$1F2\r"),
            _ack(b"$17\r", control="force 2:cw_limit=on"),
            _ack(b"$1O\r"),
            S(b"$19\r", b">$19A\r"),
        ),
        note="応答例 (II) >$19A: command + limit error, mode 1, motor 2.",
        needs={"mode": "1", "sensor": "motor 2 cw_limit ON"},
    ),
    Example(
        "§10 C",
        2944,
        (S(b"$1C\r", b">$12F\r", control="inputs 0,1,2,3,5 on"),),
        note="応答例 >$12F: bits 0-3 and 5 ON.",
        needs={"inputs": "0,1,2,3,5 ON"},
    ),
)
