"""A simulated loop as ``serve --simulate`` describes it, and the line to it.

``SimulatedLine`` is what the API process sends a line worker for each simulated loop (in
its ``LoopSpec.line``): plain, picklable facts (the bodies, their series, where their
EEPROM files are, the scene, the clock). The worker builds the simulator from it
(``build_simulator``) and puts ``sim_line`` between it and the scheduler, in its own
process: a restarted worker builds it afresh (its controllers powered on again, their
settings read back from the EEPROM files).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from gateway.protocol.framing import Series
from gateway.sim.cli import build_loop
from gateway.sim.clock import SimClock
from gateway.sim.control import Controls
from gateway.sim.loop import SimLoop
from gateway.sim.scene import Scene
from gateway.sim.serve import SimPort
from gateway.transport.pipe import PipeTransport

__all__ = ["SimulatedLine", "build_simulator", "sim_line"]


@dataclass(frozen=True)
class SimulatedLine:
    """One simulated loop: its controllers and how its simulator runs."""

    bodies: tuple[str, ...]
    series: Series
    #: the controllers' EEPROM files (each loop its own: one body number on two loops is two
    #: units)
    eeprom_dir: Path
    #: the sensors' layout (None: the simulator's default scene)
    scene: Scene | None
    #: simulated seconds per real second
    time_scale: float
    #: replies on time to some 0.05 ms (a timer thread), or asyncio's timers (``--clock``)
    precise: bool
    #: the listening socket of the control surface, inherited from the API process (None:
    #: no ``--control``, or another loop's)
    control_fd: int | None = None


def build_simulator(line: SimulatedLine) -> SimLoop:
    """The simulated loop ``line`` describes, its clock started now."""
    clock = SimClock(line.time_scale, precise=line.precise)
    return build_loop(
        list(line.bodies),
        series=line.series,
        scene=line.scene,
        eeprom_dir=line.eeprom_dir,
        clock=clock,
    )


def sim_line(sim: SimLoop) -> PipeTransport:
    """The line to ``sim`` in the same process: opened at another rate (``POST
    /loops/{loop}/baud``), it sets the simulated line's rate, the host's UART, so controllers
    at another rate hear noise as on a real line."""

    def connect() -> SimPort:
        if sim.baud != line.baud:
            Controls(sim).baud(line.baud)
        return SimPort(sim)

    line = PipeTransport(connect)
    return line
