"""``serve --simulate``'s lines: the in-process simulator behind each loop.

One simulated loop per loop of the ``--config`` file (its controllers, at 9600 bps, one
series a loop), or the loop ``sim`` of ``simulated_config`` without a file; each loop's
transport is a pipe to its ``SimLoop`` in this process. These loops run in the API process
(``Runtime``'s in-process form): the simulator lives here, and its control surface with it.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from gateway.protocol.framing import Series
from gateway.service.config import ConfigError, GatewayConfig
from gateway.service.runtime.simulated import SIM_LOOP, simulated_config
from gateway.sim.cli import build_loop, default_eeprom_dir
from gateway.sim.clock import SimClock
from gateway.sim.control import Controls
from gateway.sim.loop import SimLoop
from gateway.sim.scene import load_scene
from gateway.sim.serve import SimPort
from gateway.transport.base import Transport
from gateway.transport.pipe import PipeTransport

__all__ = ["sim_line", "simulated_lines"]


def simulated_lines(
    args: argparse.Namespace, config: GatewayConfig | None
) -> tuple[GatewayConfig, list[SimLoop], dict[str, Transport]]:
    """The simulated loops: one per loop of ``config`` (its controllers), or ``sim``."""
    scene = load_scene(args.scene) if args.scene else None
    eeprom_dir: Path = args.eeprom_dir or default_eeprom_dir()
    if config is None:
        config = simulated_config(args.bodies)
        wanted = [(SIM_LOOP, list(args.bodies), Series.DOLLAR, eeprom_dir)]
    else:
        wanted = []
        for i, loop in enumerate(config.loops):
            if loop.baud != 9600:
                raise ConfigError(f"loops[{i}].baud: simulated controllers answer at 9600 bps")
            marks = {c.series for c in loop.controllers}
            if len(marks) > 1:
                raise ConfigError(f"loops[{i}].controllers: simulated loops have one series")
            bodies = [c.body for c in loop.controllers]
            # Each loop its own EEPROM files: the same body number on two loops is two units.
            wanted.append((loop.name, bodies, Series(marks.pop()), eeprom_dir / loop.name))
    sims: list[SimLoop] = []
    transports: dict[str, Transport] = {}
    for name, bodies, series, eeproms in wanted:
        clock = SimClock(args.time_scale, precise=args.clock == "precise")
        sim = build_loop(bodies, series=series, scene=scene, eeprom_dir=eeproms, clock=clock)
        sims.append(sim)
        transports[name] = sim_line(sim)
    return config, sims, transports


def sim_line(sim: SimLoop) -> PipeTransport:
    """The in-process line to ``sim``: opened at another rate (``POST /loops/{loop}/baud``),
    it sets the simulated line's rate, the host's UART, so controllers at another rate hear
    noise as on a real line."""

    def connect() -> SimPort:
        if sim.baud != line.baud:
            Controls(sim).baud(line.baud)
        return SimPort(sim)

    line = PipeTransport(connect)
    return line
