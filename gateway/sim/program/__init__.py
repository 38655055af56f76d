"""The user-program interpreter of the simulated RC-233 (chapters 11 and 12).

``machine.Machine`` runs the RAM program statement by statement in simulated time;
``statements`` carries out the chapter-12 commands, ``host`` the host commands written as
``/cmd``, ``flow`` the jumps, ``timing`` the waits and the shared timer, ``output`` what the
program sends to the host.
"""

from gateway.sim.program.machine import Machine
from gateway.sim.program.timing import STEP_SECONDS

__all__ = ["STEP_SECONDS", "Machine"]
