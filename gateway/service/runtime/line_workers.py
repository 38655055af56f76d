"""The loops of a configuration run in line worker processes: the API process's side.

``LineWorkers(config, topology, time_scale)`` groups the loops (``[engine] workers``, or the
default of ``worker_groups``), and for each group holds a ``WorkerClient`` (the schedulers'
proxies, the pollers') and a ``WorkerSupervisor`` (the process, started again with back-off
when it dies); one ``StateMirror`` follows every worker. ``Runtime`` offers the proxies as
its ``schedulers``, the mirror as its ``state``: service/ and the faces read them as they
read the schedulers and cache of one process.

``lines`` (``WorkerLines``): the workers build their loops' lines themselves, each from what
``lines.lines`` holds for it, running ``lines.program`` (``serve --simulate``: a simulator in
the worker beside the scheduler that talks to it); without it each opens its loops' ports.
"""

from __future__ import annotations

import asyncio

from gateway.engine.mirror import StateMirror
from gateway.engine.proxy import SchedulerProxy, WorkerClient
from gateway.engine.scheduler_reads import PollerProxy
from gateway.engine.supervisor import WorkerSupervisor
from gateway.engine.worker_spec import LoopSpec, WorkerLines
from gateway.service.config import GatewayConfig
from gateway.service.config_engine import worker_groups
from gateway.service.runtime.loop_configs import loop_config, poll_config
from gateway.service.topology import Topology

__all__ = ["LineWorkers"]


class LineWorkers:
    """Every worker process of a configuration, their clients and the mirror they feed."""

    def __init__(
        self,
        config: GatewayConfig,
        topology: Topology,
        time_scale: float,
        *,
        cores: int | None = None,
        lines: WorkerLines | None = None,
    ) -> None:
        self.mirror = StateMirror()
        self.schedulers: dict[str, SchedulerProxy] = {}
        self.pollers: dict[str, PollerProxy] = {}
        self.supervisors: list[WorkerSupervisor] = []
        refs = {ref.name: ref for ref in topology.loops()}
        groups = worker_groups(config.engine, list(refs), cores)
        for group in groups:
            specs = []
            for name in group:
                ref = refs[name]
                specs.append(
                    LoopSpec(
                        loop_config(ref.settings, ref, time_scale),
                        poll_config(ref.settings),
                        tuple(ref.bodies),
                        ref.settings.port,
                        ref.settings.baud,
                        None if lines is None else lines.lines[name],
                    )
                )
            worker = "+".join(group)
            client = WorkerClient(worker, group, self.mirror, {s.name: s.config for s in specs})
            self.schedulers.update(client.proxies)
            self.pollers.update(client.pollers)
            backoff = config.engine.restart_backoff
            program = None if lines is None else lines.program
            self.supervisors.append(
                WorkerSupervisor(client, specs, backoff=backoff, program=program)
            )

    def follow(self, controllers: frozenset[tuple[str, str]]) -> None:
        """Relay the reply events of ``controllers`` (loop, body) only, each worker told of
        its own."""
        for supervisor in self.supervisors:
            client = supervisor.client
            own = frozenset(c for c in controllers if c[0] in client.proxies)
            if own != client.followed:
                client.follow(own)

    async def start(self) -> None:
        """Start every worker; returns once each has sent its first snapshot (or died: its
        loops are down with the cause, and it starts again after its back-off)."""
        await asyncio.gather(*(s.start() for s in self.supervisors))

    async def close(self, *, drain: float) -> None:
        """Let every worker finish its transaction in flight and exit."""
        await asyncio.gather(*(s.close(drain=drain) for s in self.supervisors))
