"""The user-program interpreter of one simulated RC-233 (chapters 11 and 12).

A ``Machine`` holds the program the host started with ``G`` (or ``GA`` at power-on): its
statements, what it waits for, its subroutine returns and the ``/TS`` stop wait. Where it
stands is ``Runtime.step`` (what ``GN`` reads) and how it stands is ``Runtime.program_state``
(what ``GSS`` reads), so the host commands see the same values the machine uses.

Time: like the rest of the simulator the machine never reads a clock. ``run(ctl, now)``
executes every statement due by ``now``; ``next_time(ctl)`` says when it next has something
to do (None: not by itself), so the loop can wake it (``Controller.wake_at`` / ``wake``). A
statement takes ``STEP_SECONDS`` (the manual gives no figure; docs/manual-notes.md "Statement
time"). Waits end at the simulated time of their event: the end of a motion, time-up of the
timer, the end of an EEPROM write.

Statements are checked when they run, as the device does (§10 G 注意点: a command error inside
the program ends it there, GSS reads E, GN names the statement). A loop of jumps that changes
nothing (``/JOF1-1``, ``/JM-1``) is recognised after one round and then sleeps until something
it reads can change (a motion ends, the timer runs out, the host or the control surface acts:
``nudge``), so a program polling an input costs nothing while it waits.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from gateway.errors import InvalidInputError
from gateway.protocol.command_text import parse_statement
from gateway.protocol.models import Command
from gateway.protocol.params import PositionFormat
from gateway.protocol.reply_values import ProgramState
from gateway.sim.dispatch import Refused
from gateway.sim.flags import Error
from gateway.sim.program import host, statements
from gateway.sim.program.output import error_mark
from gateway.sim.program.timing import (
    STEP_SECONDS,
    Wait,
    motion_end,
    start_timer,
    timer_end,
)

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

__all__ = ["Machine"]

#: Statements one ``run`` executes at most; the rest wait for the next wake (no endless loop).
_BUDGET = 100_000
#: Float slack when comparing a time with the timer's end (0.1 s units, §10 T).
_EPS = 1e-9

_ACTIVE = (ProgramState.RUNNING, ProgramState.PAUSED)


class Machine:
    """One run of the RAM program, from ``G`` until ``/END``, an error, ``GE`` or ``GES``."""

    def __init__(self, text: str) -> None:
        # Every statement starts with '/'; the text was checked to start with one (§10 I).
        self.bodies = text[1:].split("/")
        #: label -> the step of its first '/G{label}' (a label statement is 'G' + one char)
        self.labels: dict[str, int] = {}
        for step, body in enumerate(self.bodies, 1):
            if len(body) == 2 and body[0] == "G":
                self.labels.setdefault(body[1], step)
        self.time = 0.0  # when the machine next acts, at the earliest
        self.wait: Wait | None = None
        self.until = 0.0  # end of a Wait.UNTIL
        self.calls: list[int] = []  # return steps of /SC
        self.stop_wait = 0  # /TS: tenths of a second after each NULL wait
        self.current = 0  # the step being executed (for the statements)
        self.jump_to: int | None = None  # set by a statement that jumps
        self.pure = False  # set by a statement that changed nothing (a jump, a label)
        self.reads_motion = False  # set by a jump whose answer changes while a motor turns
        self.idle = False
        self._visited: set[int] = set()
        self._cycle_motion = False
        self._parsed: dict[tuple[str, PositionFormat], Command | InvalidInputError] = {}

    @property
    def size(self) -> int:
        """Number of statements (the GN of the last one)."""
        return len(self.bodies)

    # ------------------------------------------------------------------ host control

    def start(self, ctl: ControllerView, step: int, now: float) -> None:
        """Run from ``step``; the first statement executes one statement time after ``now``."""
        ctl.rt.step = step
        ctl.rt.program_state = ProgramState.RUNNING
        self.time = now + STEP_SECONDS
        self.wait = None
        self.calls.clear()
        self.stop_wait = 0
        self._wake_up(now)

    def resume(self, now: float) -> None:
        """GC: go on from where GS paused it (§10 GC)."""
        self._wake_up(now)

    def nudge(self, now: float) -> None:
        """Something the program may read changed at ``now`` (host command, input, EMS).

        A round of jumps under way starts over: what it read before ``now`` is stale.
        """
        self._wake_up(now)

    def _wake_up(self, now: float) -> None:
        self.idle = False
        self._visited.clear()
        self._cycle_motion = False
        self.time = max(self.time, now)

    def end(self, ctl: ControllerView) -> None:
        """The program ends now (``/END``, ``/?``, ``GE``, ``GES``); GN keeps its step."""
        ctl.rt.program_state = ProgramState.ENDED
        self.wait = None

    # ------------------------------------------------------------------ time

    def next_time(self, ctl: ControllerView) -> float | None:
        """When the machine next acts by itself; None while it only waits for the outside."""
        state = ctl.rt.program_state
        if state not in _ACTIVE:
            return None
        if self.wait is Wait.MOTION:
            end = motion_end(ctl)
            if end is None:
                return self.time
            return None if math.isinf(end) else max(self.time, end)
        if self.wait is Wait.TIMER:
            return max(self.time, timer_end(ctl.rt.timer))
        if self.wait is Wait.UNTIL:
            return max(self.time, self.until)
        if state is ProgramState.PAUSED:
            return None  # GS: paused at a statement boundary (§10 GS)
        if not self.idle:
            return self.time
        events: list[float] = []
        end = motion_end(ctl)
        if end is not None:
            if self._cycle_motion:
                return self.time  # it polls a position or a sensor of a turning motor
            if not math.isinf(end):
                events.append(end)
        timer = ctl.rt.timer
        if not timer.timed_up(self.time):
            events.append(timer_end(timer))
        return max(self.time, min(events)) if events else None

    def run(self, ctl: ControllerView, now: float) -> None:
        """Execute everything due by ``now``: wait ends and statements, in time order."""
        for _ in range(_BUDGET):
            t = self.next_time(ctl)
            if t is None or t > now:
                return
            self.time = t
            ctl.advance(t)
            if self.wait is not None:
                self._check_wait(ctl, t)
            else:
                if self.idle:
                    self._wake_up(t)  # an event it sleeps on has come: look again
                self._execute(ctl, t)

    def _check_wait(self, ctl: ControllerView, t: float) -> None:
        if self.wait is Wait.MOTION:
            if ctl.moving_motor(t) is not None:
                return  # a search goes on with its next step
            if self.stop_wait:
                start_timer(ctl, self.stop_wait, t)  # §12 /TS: then the stop wait
                self.wait = Wait.TIMER
                return
        elif self.wait is Wait.TIMER:
            if t + _EPS < timer_end(ctl.rt.timer):
                return  # GWT or T moved the end of the shared timer (§10 GWT)
        elif t + _EPS < self.until:
            return
        self.wait = None
        self.time = t + STEP_SECONDS

    # ------------------------------------------------------------------ statements

    def _execute(self, ctl: ControllerView, t: float) -> None:
        step = ctl.rt.step
        self.current = step
        self.jump_to, self.pure, self.reads_motion = None, False, False
        self.time = t + STEP_SECONDS
        try:
            if not 1 <= step <= self.size:
                # Only text uploaded without a final /END gets here (§11-3: /END is required).
                raise Refused("the program ran past its last statement")
            command = self._parse(ctl, step)
            ctl.rt.step = step + 1  # GN names the statement that runs next (§10 GN)
            if command.spec.program_only:
                statements.execute(self, ctl, command, t)
            else:
                host.execute(ctl, command, t)
        except Refused:
            self._fail(ctl, step, t)
            return
        if self.jump_to is not None:
            ctl.rt.step = self.jump_to
        self._note_cycle(step, ctl.rt.step)

    def _parse(self, ctl: ControllerView, step: int) -> Command:
        """The statement at ``step``; parsed when it runs, in the position format in force."""
        body, positions = self.bodies[step - 1], ctl.position_format
        found = self._parsed.get((body, positions))
        if found is None:
            try:
                found = parse_statement(body, positions=positions)
            except InvalidInputError as exc:
                found = exc
            self._parsed[(body, positions)] = found
        if isinstance(found, InvalidInputError):
            raise Refused(f"/{body}: {found}")
        return found

    def _fail(self, ctl: ControllerView, step: int, t: float) -> None:
        """A command error inside the program: it ends there (§10 G, GSS, GN, ER)."""
        ctl.rt.step = step
        ctl.rt.program_state = ProgramState.ERROR
        ctl.flags.raise_(Error.COMMAND)
        self.wait = None
        if ctl.framing.error_mark:
            ctl.emit(t, error_mark())  # §10 ER 注意点: '@' alone, and the program ends

    def _note_cycle(self, step: int, following: int) -> None:
        """Recognise a round of jumps that changed nothing: the machine then sleeps."""
        if not self.pure:
            self._visited.clear()
            self._cycle_motion = False
            return
        self._visited.add(step)
        self._cycle_motion |= self.reads_motion
        if following in self._visited:
            self.idle = True
