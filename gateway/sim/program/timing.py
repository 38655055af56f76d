"""Time in a running program: the statement time, the waits, the shared timer (§12, §10 T).

The RC-233 has one internal timer that ``T``, ``T*``, ``P``, ``GWT`` and the program's ``/T``,
``/TB``, ``/TS`` share (§10 T 注意点, §12 /T 注意). A program's timer never sends ``$B#T``:
that message belongs to the host's ``T`` form I (§10 T).
"""

from __future__ import annotations

from enum import Enum
from typing import TYPE_CHECKING, Protocol

from gateway.sim.ram_state import Timer

if TYPE_CHECKING:
    from gateway.sim.controller_view import ControllerView

__all__ = [
    "MAX_CALLS",
    "STEP_SECONDS",
    "StatementRun",
    "Wait",
    "motion_end",
    "start_timer",
    "timer_end",
]

#: Simulated time one statement takes. Not in the manual; §12 /JP 注意 (a polling loop misses
#: positions of a turning motor) only says it is not negligible (docs: "Statement time").
STEP_SECONDS = 0.002
#: Subroutine calls nest up to five levels (§12 /SC); a sixth is a command error (our choice).
MAX_CALLS = 5


class Wait(Enum):
    """What a statement waits for before the next one runs."""

    MOTION = "motion"  # '/' (NULL): no motor turns (§12 /)
    TIMER = "timer"  # /T, and /TS after a NULL: the timer is up (§12 /T, /TS)
    UNTIL = "until"  # /WAW, /WDW: the EEPROM write has ended (§12 /WAW)


class StatementRun(Protocol):
    """What a statement reads and sets of the run it belongs to (``machine.Machine``): where it
    stands, where it goes next and what it waits for. The machine acts on these after each
    statement; the statements never drive the machine themselves, except to end it."""

    labels: dict[str, int]
    current: int  # the step being executed
    jump_to: int | None  # set by a statement that jumps
    pure: bool  # set by a statement that changed nothing (a jump, a label)
    reads_motion: bool  # set by a jump whose answer changes while a motor turns
    wait: Wait | None
    until: float  # end of a Wait.UNTIL
    calls: list[int]  # return steps of /SC
    stop_wait: int  # /TS: tenths of a second after each NULL wait

    @property
    def size(self) -> int:
        """Number of statements."""
        ...

    def end(self, ctl: ControllerView) -> None:
        """The program ends now; GN keeps its step."""
        ...


def timer_end(timer: Timer) -> float:
    """Simulated time at which ``timer`` runs out (§10 T: TIME x 100 ms)."""
    return timer.started + timer.tenths / 10


def start_timer(ctl: ControllerView, tenths: int, t: float) -> None:
    """Start the internal timer for the program, without ``$B#T`` (§12 /T, /TB, /TS)."""
    ctl.rt.timer = Timer(started=t, tenths=tenths, report=False)


def motion_end(ctl: ControllerView) -> float | None:
    """When the running motion (or the step of a search) ends; None if no motor turns.

    ``math.inf`` for a motion nothing ends by itself (a 7/8 jog without a limit in its way).
    """
    # Axis has no public "next event" time; its task's end_time is exactly that (the end of
    # the profile, or earlier at a limit or a search condition).
    ends = [axis._task.end_time for axis in ctl.axes.values() if axis._task is not None]
    return min(ends) if ends else None
