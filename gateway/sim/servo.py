"""Mode 2: the servo driver's INP signal, the CLR pulses, the INP wait after a motion
(§6-3, §10 CI, DS, 0X; §13-2 mode 2).

A pulse-train servo keeps turning after the controller's last pulse (its "たまりパルス",
§6 *1) and reports in-position on INP; the RC-233 waits for INP at most 3 s after pulse output
ends, and without it pulses CLR for 100 µs and sets the limit error (§10 CI 解説, §10 DS ③,
§10 9 ⑦). The simulated driver turns INP ON ``settle`` seconds (the scene's ``inp_delay``)
after pulse output stops and OFF while pulses go out, unless the control surface holds INP
OFF or gives it (``hold``). INP is the driver's in-position state as the controller reads it:
the simulated driver is wired to match the EA logic (bit 5, e.g. ``EA51B`` of §13-2).

CLR pulses (§10 DS ①-⑥) are kept by time: ``DS`` reads a CLR terminal ON during the 100 µs
of a pulse, which is as much as the manual lets a host see of one.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Generator
from dataclasses import dataclass, field

from gateway.sim.homing import Action, Ending, Finish, Outcome, PulseClr, WaitInp

__all__ = ["CLR_PULSE", "Servo", "inp_plan"]

#: §10 DS, §10 0X: the CLR output is ON for 100 µs.
CLR_PULSE = 100e-6
#: How many CLR pulses the axis remembers (for ``DS`` and the control surface's ``state``).
CLR_KEPT = 16


@dataclass
class Servo:
    """The servo driver of one axis as the RC-233 sees it: INP, and the CLR pulses it got."""

    settle: float = 0.0  # seconds from the last pulse to INP ON (the scene's inp_delay)
    active: bool = False  # mode 2: the INP/CLR terminals serve the driver (§10 E)
    hold: bool | None = None  # the control surface: INP given (True), held OFF (False)
    pulses_end: float = -math.inf  # when pulse output last stopped
    clr: deque[float] = field(default_factory=lambda: deque(maxlen=CLR_KEPT))

    def inp_at(self, t: float) -> float:
        """From when on (at or after t, with no pulses going out) INP is ON; ``inf``: never."""
        if self.hold is not None:
            return t if self.hold else math.inf
        return max(t, self.pulses_end + self.settle)

    def inp(self, now: float, pulsing: bool) -> bool:
        """INP at ``now`` (§10 CI): OFF while pulses go out, unless given by the control."""
        if self.hold is not None:
            return self.hold
        return not pulsing and now >= self.pulses_end + self.settle

    def pulse_clr(self, t: float) -> None:
        """A CLR pulse starts at t."""
        self.clr.append(t)

    def clr_on(self, now: float) -> bool:
        """Whether a CLR pulse is ON at ``now``."""
        return any(t <= now < t + CLR_PULSE for t in self.clr)


def inp_plan() -> Generator[Action, Outcome, None]:
    """After a motion in mode 2: INP within 3 s, else CLR and limit error (§10 CI, DS ③)."""
    out = yield WaitInp()
    if out.ending is Ending.TIMEOUT:
        yield PulseClr()
        yield Finish(False)
