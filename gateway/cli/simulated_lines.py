"""``serve --simulate``'s lines: a simulator behind each loop, in the loop's line worker.

One simulated loop per loop of the ``--config`` file (its controllers, at 9600 bps, one
series a loop), or the loop ``sim`` of ``simulated_config`` without a file. The API process
only describes them (``SimulatedLine``) and checks what it can first (the scene, the rates,
the series, the control port), so that a mistake stops ``serve`` with a message; each loop's
worker (``gateway.cli.simulated_worker``) builds its simulator and talks to it over the
in-process pipe, as the engine talks to a real port: one engine code path.

``--control HOST:PORT`` is bound here, once, and inherited by the workers; the one holding
the first loop serves the first loop's simulator on it (as ``rc233-gateway sim --control``).
"""

from __future__ import annotations

import argparse
import os
import socket
from pathlib import Path

from gateway.cli.simulated_line import SimulatedLine, sim_line
from gateway.cli.simulated_worker import simulated_program
from gateway.engine.worker_spec import WorkerLines
from gateway.protocol.framing import Series
from gateway.service.config import ConfigError, GatewayConfig
from gateway.service.runtime.simulated import SIM_LOOP, simulated_config
from gateway.sim.cli import default_eeprom_dir
from gateway.sim.scene import load_scene

__all__ = ["SimulatedCell", "sim_line", "simulated_lines"]


class SimulatedCell:
    """The simulated loops of ``serve --simulate``: the configuration they serve, what each
    worker builds them from, and the control surface's socket (closed by ``close``)."""

    def __init__(
        self, config: GatewayConfig, lines: WorkerLines, control: socket.socket | None
    ) -> None:
        self.config = config
        self.lines = lines
        self.control = control

    def close(self) -> None:
        """Close the control surface's socket (the workers have exited)."""
        if self.control is not None:
            self.control.close()


def simulated_lines(args: argparse.Namespace, config: GatewayConfig | None) -> SimulatedCell:
    """The simulated loops: one per loop of ``config`` (its controllers), or ``sim``."""
    scene = load_scene(args.scene) if args.scene else None
    # absolute: the worker reads it, and a relative path would be the worker's to interpret
    eeprom_dir: Path = (args.eeprom_dir or default_eeprom_dir()).absolute()
    if config is None:
        config = simulated_config(args.bodies)
        wanted = [(SIM_LOOP, tuple(args.bodies), Series.DOLLAR, eeprom_dir)]
    else:
        wanted = []
        for i, loop in enumerate(config.loops):
            if loop.baud != 9600:
                raise ConfigError(f"loops[{i}].baud: simulated controllers answer at 9600 bps")
            marks = {c.series for c in loop.controllers}
            if len(marks) > 1:
                raise ConfigError(f"loops[{i}].controllers: simulated loops have one series")
            bodies = tuple(c.body for c in loop.controllers)
            # Each loop its own EEPROM files: the same body number on two loops is two units.
            wanted.append((loop.name, bodies, Series(marks.pop()), eeprom_dir / loop.name))
    control = _control_socket(args.control) if args.control else None
    lines: dict[str, object] = {}
    for name, bodies, series, eeproms in wanted:
        lines[name] = SimulatedLine(
            bodies,
            series,
            eeproms,
            scene,
            args.time_scale,
            precise=args.clock == "precise",
            control_fd=control.fileno() if control is not None and not lines else None,
        )
    return SimulatedCell(config, WorkerLines(simulated_program(control), lines), control)


def _control_socket(address: tuple[str, int]) -> socket.socket:
    """The control surface's listening socket (``ConfigError`` naming ``--control`` when it
    cannot listen there: the port is taken, the host is not this machine's)."""
    host, port = address
    try:
        family = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0][0]
        return socket.create_server((host, port), family=family, backlog=16)
    except OSError as exc:
        # create_server words its own strerror (the address again): the errno's is enough
        errno = exc.errno or 0
        plain = errno > 0 and not isinstance(exc, socket.gaierror)
        reason = os.strerror(errno) if plain else (exc.strerror or str(exc))
        raise ConfigError(f"--control {host}:{port}: cannot listen there ({reason})") from None
