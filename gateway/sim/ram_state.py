"""RAM-only state of a simulated RC-233 that is not a ``DW`` setting.

The I/O port, the timer, the user program and its buffers and counters, and the ``B`` sequence.
The program's interpreter (``gateway.sim.program.Machine``) keeps its own run state; where it
stands (``step``, GN) and how (``program_state``, GSS) live here, where the host commands read
them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

from gateway.protocol.reply_values import ClrState, ProgramState

__all__ = ["ProgramRun", "Runtime", "Timer"]


class ProgramRun(Protocol):
    """A started user program as the controller and the host commands drive it
    (``gateway.sim.program.Machine``).

    ``ctl`` is the controller (``sim.controller_view.ControllerView``); typed Any here because
    the controller view holds this runtime: naming it would make the two import each other.
    """

    def run(self, ctl: Any, now: float) -> None:
        """Do what the program has to do up to ``now``."""
        ...

    def next_time(self, ctl: Any) -> float | None:
        """When the program next acts by itself (None: it waits for the outside)."""
        ...

    def nudge(self, now: float) -> None:
        """Something outside changed: a program polling in a loop looks again."""
        ...

    def resume(self, now: float) -> None:
        """Go on after a pause (GC)."""
        ...

    def end(self, ctl: Any) -> None:
        """End the program (GE, GES)."""
        ...


@dataclass
class Timer:
    """The internal timer of ``T``/``T*``/``GWT`` (§10 T, GRT, GWT), in 0.1 s units."""

    started: float = 0.0
    tenths: int = 0
    report: bool = False  # T (sends $B#T at time-up) rather than T*

    def remaining(self, now: float) -> int:
        """Tenths of a second left (GRT), 0 once timed up."""
        left = self.tenths - int((now - self.started) * 10 + 1e-9)
        return max(left, 0)

    def timed_up(self, now: float) -> bool:
        """True once the time has run out (query T answers 1, §10 T)."""
        return self.remaining(now) == 0


@dataclass
class Runtime:
    """The controller's RAM apart from the settings."""

    program: str = ""  # the RAM user program (§10 I, IR)
    autostart: bool = False  # GA
    awaiting_program: bool = False  # between the '>' of I and the CR of the program text
    program_state: ProgramState = ProgramState.ENDED
    step: int = 0  # GN: the next statement's position, counted in '/' (§10 GN)
    machine: ProgramRun | None = None  # the last program G (or GA) started
    inputs: int = 0  # general inputs 7-0 (C)
    inp: tuple[bool, bool] = (False, False)  # INP1, INP2 (C8, C9, CA, CI)
    outputs: int = 0  # general outputs 7-0 (D, CO)
    clr: ClrState = ClrState()  # CLR1, CLR2 (D8xB, D9xB, DA, DS)
    buffers: dict[str, int] = field(default_factory=dict)  # GW{bf} / GR{bf}
    counters: dict[int, int] = field(default_factory=dict)  # GW{ct} / GR{ct}
    timer: Timer = field(default_factory=Timer)
    pulse: int | None = None  # the output bit P turned ON, until the timer runs out
    #: Number of the entry the next sequential B / B+(-) uses; None = never set since power-on
    #: (BN then reads 00000 and the next B uses 001, §10 B 注意点).
    next_entry: int | None = None

    @classmethod
    def power_on(cls, stored_program: str | None, autostart: bool) -> Runtime:
        """RAM at power-on: the IW program loaded (IL runs by itself, §10 IL), GA flag read."""
        return cls(program=stored_program or "", autostart=autostart)

    @property
    def program_running(self) -> bool:
        """True while a user program runs or is paused (§11-3 5.)."""
        return self.program_state in (ProgramState.RUNNING, ProgramState.PAUSED)

    def take_program_text(self, text: str) -> bool:
        """The program text after ``I``; False (command error) when it does not start with '/'.

        §10 I: the first character must be '/', otherwise the reply is still '>' with the
        command-error flag and nothing is stored. The device checks nothing else at upload: a
        bad statement shows when the program runs (a command error then), so the text is kept
        as sent.
        """
        self.awaiting_program = False
        if not text.startswith("/"):
            return False
        self.program = text
        return True

    def set_input(self, bit: int, on: bool) -> None:
        """Drive general input ``bit`` (0-7), or INP1/INP2 as bits 8 and 9."""
        if bit in (8, 9):
            inp = list(self.inp)
            inp[bit - 8] = on
            self.inp = (inp[0], inp[1])
            return
        if not 0 <= bit <= 7:
            raise ValueError(f"input bit must be 0-9, got {bit}")
        self.inputs = self.inputs | (1 << bit) if on else self.inputs & ~(1 << bit)
