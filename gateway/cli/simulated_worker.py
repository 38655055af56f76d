"""``serve --simulate``'s line worker: ``python -m gateway.cli.simulated_worker REQ STOP``.

The engine's worker (``gateway.engine.process``) with its lines built here: each loop's
simulator (``SimulatedLine`` in its ``LoopSpec.line``) lives in this process beside the
scheduler that talks to it, over the in-process pipe (``sim_line``), so a simulated cell runs
the same engine, across the same process boundary, as a real one. The worker that holds the
loop with the control surface's socket serves it (``--control``), on the socket the API
process bound: the port stays the same when the worker is started again.

The gateway proper never imports the simulator; this program is the command line's, which
may.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
from collections.abc import AsyncIterator, Mapping, Sequence

from gateway.cli.simulated_line import SimulatedLine, build_simulator, sim_line
from gateway.engine.process import main
from gateway.engine.worker_spec import LoopSpec, WorkerProgram
from gateway.sim.control import Controls, serve_control_on
from gateway.sim.loop import SimLoop
from gateway.transport.base import Transport

__all__ = ["SIMULATED_WORKER", "open_simulated", "simulated_program"]

#: The module a simulated cell's workers run.
SIMULATED_WORKER = "gateway.cli.simulated_worker"


def simulated_program(control: socket.socket | None) -> WorkerProgram:
    """The program of ``serve --simulate``'s workers, inheriting the control surface's
    listening socket if there is one."""
    return WorkerProgram(SIMULATED_WORKER, () if control is None else (control.fileno(),))


@contextlib.asynccontextmanager
async def open_simulated(specs: Sequence[LoopSpec]) -> AsyncIterator[Mapping[str, Transport]]:
    """Each loop's simulator and the line to it; the simulators (and the control surface)
    close when the worker is done with them."""
    sims: list[SimLoop] = []
    control: asyncio.Server | None = None
    try:
        lines: dict[str, Transport] = {}
        for spec in specs:
            described = spec.line
            if not isinstance(described, SimulatedLine):
                raise SystemExit(f"simulated worker: loop {spec.name} has no simulated line")
            sim = build_simulator(described)
            sims.append(sim)
            lines[spec.name] = sim_line(sim)
            if described.control_fd is not None:
                listening = socket.socket(fileno=described.control_fd)
                control = await serve_control_on(Controls(sim), listening)
        yield lines
    finally:
        if control is not None:
            control.close()
        for sim in sims:
            sim.close()


if __name__ == "__main__":
    main(open_simulated)
