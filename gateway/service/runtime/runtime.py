"""The running gateway: one scheduler and poller per configured loop, one state cache for all.

The loops run in line worker processes (``Runtime(config)``: ``LineWorkers``, the workers
grouped by ``[engine] workers``): ``schedulers`` are the workers' proxies, ``state`` the
mirror their changes feed, ``pollers`` switch the workers' pollers. ``worker_lines``: the
workers build their lines themselves (``serve --simulate``: a simulator in each worker)
instead of opening the loops' ports. Every command a user runs (``serve``, with or without
``--simulate``) takes that path. ``Runtime(config, transports=...)`` runs the loops in this
process on the transports given, one per loop: the seam the tests put a line behind, and
nothing else; service/ and the faces read either form through the same surface
(``gateway.engine.surface``).

Building a ``Runtime`` touches no port and starts no process; ``await start()`` starts the
workers (or opens every loop: one attempt each; a loop that cannot open now keeps trying in
the background, and requests to it fail with ``LoopDown`` meanwhile) and starts polling;
``await close()`` stops accepting, lets the transaction in flight on each loop finish,
closes the ports (the workers exit) and then the state store (``store``: the state
directory's database, opened by the owner of the process; in memory when none is given).
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Mapping
from types import MappingProxyType

from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import BusEvent, LinkDown, LinkUp, UnsolicitedMessage
from gateway.bus.poller import Poller, attach
from gateway.bus.scheduler import LinkState, LoopScheduler
from gateway.bus.state import StateCache
from gateway.engine.surface import LinePoller, LineScheduler
from gateway.engine.worker_spec import WorkerLines
from gateway.protocol.commands import position
from gateway.protocol.reply_parser import UnsolicitedKind
from gateway.service.config import GatewayConfig
from gateway.service.control import ControlStates
from gateway.service.events import EventKind, ServiceEvent, ServiceEvents
from gateway.service.runtime.followed import FollowedControllers
from gateway.service.runtime.key_switch import KeySwitchReader
from gateway.service.runtime.line_workers import LineWorkers
from gateway.service.runtime.loop_configs import loop_config, poll_config
from gateway.service.runtime.origin_watch import OriginWatch
from gateway.service.store.database import StateStore
from gateway.service.topology import Topology
from gateway.transport.base import Transport

__all__ = ["Runtime", "loop_config", "poll_config"]

log = logging.getLogger("gateway.service")

#: Real seconds ``close`` lets a transaction in flight finish.
DRAIN_SECONDS = 5.0


class Runtime:
    """The running gateway: every loop of a configuration, its state cache, service events,
    control states and key switch reader (what the faces are built on)."""

    def __init__(
        self,
        config: GatewayConfig,
        *,
        transports: Mapping[str, Transport] | None = None,
        time_scale: float = 1.0,
        store: StateStore | None = None,
        worker_lines: WorkerLines | None = None,
    ) -> None:
        self.config = config
        #: what must outlive the process (operations, idempotency keys, counters); in memory
        #: unless the owner of the process opened the state directory's
        self.store = store if store is not None else StateStore.memory()
        self.topology = Topology(config)
        self.events = ServiceEvents()
        self.time_scale = time_scale
        self.started = time.time()
        #: the line workers (None: the loops run in this process, on ``transports``)
        self.workers: LineWorkers | None = None
        self.schedulers: dict[str, LineScheduler]
        self.pollers: dict[str, LinePoller]
        #: which controllers' replies the workers relay (None: in one process, no channel)
        self.followed: FollowedControllers | None = None
        if transports is None:
            self.workers = LineWorkers(config, self.topology, time_scale, lines=worker_lines)
            self.followed = FollowedControllers(self.events, self.workers.follow)
            self.state: StateCache = self.workers.mirror
            self.schedulers = dict(self.workers.schedulers)
            self.pollers = dict(self.workers.pollers)
        else:
            if worker_lines is not None:
                raise ValueError("transports or worker_lines, not both")
            self.state = StateCache()
            self.schedulers, self.pollers = self._in_process(transports, time_scale)
        for scheduler in self.schedulers.values():
            scheduler.events.subscribe(self._relay)
        #: local/remote control of every controller, and the key switches' reader
        self.control = ControlStates(self.topology, self.events)
        #: the origin events and log lines (a controller reset, an origin found)
        self.origins = OriginWatch(
            self.topology,
            self.state,
            self.events,
            read_position=lambda a: self.scheduler(a.loop).submit(a.body, position(a.motor)),
        )
        self.key_switches = KeySwitchReader(self.topology, self.control, self.schedulers)

    def _in_process(
        self, transports: Mapping[str, Transport], time_scale: float
    ) -> tuple[dict[str, LineScheduler], dict[str, LinePoller]]:
        """Every loop's scheduler and poller in this process, on ``transports``."""
        lines = dict(transports)
        missing = [ref.name for ref in self.topology.loops() if ref.name not in lines]
        if missing:
            raise ValueError(f"no transport for the loops {missing}")
        self._local: dict[str, LoopScheduler] = {}
        self._local_pollers: dict[str, Poller] = {}
        for ref in self.topology.loops():
            settings = ref.settings
            scheduler = LoopScheduler(lines.pop(ref.name), loop_config(settings, ref, time_scale))
            self._local[ref.name] = scheduler
            self._local_pollers[ref.name] = attach(
                scheduler, self.state, ref.bodies, poll_config(settings)
            )
        if lines:
            raise ValueError(f"transports for loops not configured: {sorted(lines)}")
        return dict(self._local), dict(self._local_pollers)

    # ------------------------------------------------------------------ life

    async def start(self) -> None:
        """Start the workers (or open every loop: one attempt each) and start polling."""
        if self.workers is not None:
            await self.workers.start()  # each worker polls from its start
            assert self.followed is not None
            self.followed.start()
        else:
            await asyncio.gather(*(s.start() for s in self._local.values()))
            for poller in self._local_pollers.values():
                poller.start()
        for name, scheduler in self.schedulers.items():
            if scheduler.state is not LinkState.UP:
                log.warning("loop %s is not up yet: %s", name, scheduler.cause)
        self.key_switches.start()

    async def close(self, *, drain: float = DRAIN_SECONDS) -> None:
        """Stop polling, let each loop's transaction in flight finish, close the ports."""
        await self.key_switches.stop()
        if self.followed is not None:
            self.followed.close()
        if self.workers is not None:
            await self.workers.close(drain=drain)
        else:
            await asyncio.gather(*(p.stop() for p in self._local_pollers.values()))
            await asyncio.gather(*(s.close(drain=drain) for s in self._local.values()))
        await self.store.close()  # last: the ends of the operations drained above are written

    # ------------------------------------------------------------------ reading

    def scheduler(self, loop: str) -> LineScheduler:
        """The scheduler of ``loop`` (``NotFoundError`` for an unknown name)."""
        return self.schedulers[self.topology.loop(loop).name]

    def ready(self) -> bool:
        """True when every loop is up."""
        return all(s.state is LinkState.UP for s in self.schedulers.values())

    def down_loops(self) -> dict[str, str]:
        """The loops that are not up, and why."""
        return {
            name: s.cause or s.state.value
            for name, s in self.schedulers.items()
            if s.state is not LinkState.UP
        }

    def loop_counters(self, loop: str) -> CountersSnapshot:
        """The scheduler's counters of ``loop``."""
        return self.scheduler(loop).snapshot()

    def device_seconds(self, loop: str) -> float:
        """Host seconds to device seconds on ``loop`` (the simulator's time scale)."""
        return self.scheduler(loop).config.time_scale

    # ------------------------------------------------------------------ events

    def _relay(self, event: BusEvent) -> None:
        """Bus events clients want to see, as service events."""
        now = time.time()
        if isinstance(event, UnsolicitedMessage):
            kind = (
                EventKind.PROGRAM_OUTPUT
                if event.kind is UnsolicitedKind.PROGRAM_OUTPUT
                else EventKind.UNSOLICITED
            )
            topic = f"controller:{event.loop}.{event.body}" if event.body else f"loop:{event.loop}"
            self.events.publish(
                ServiceEvent(
                    kind,
                    topic,
                    now,
                    MappingProxyType(
                        {
                            "loop": event.loop,
                            "controller": f"{event.loop}.{event.body}" if event.body else None,
                            "message": event.kind.value,
                            "data": event.data,
                        }
                    ),
                )
            )
        elif isinstance(event, LinkDown | LinkUp):
            up = isinstance(event, LinkUp)
            data: dict[str, object] = {"loop": event.loop, "up": up}
            if isinstance(event, LinkDown):
                data |= {"cause": event.cause, "retry_after": event.retry_after}
            self.events.publish(
                ServiceEvent(EventKind.LINK, f"loop:{event.loop}", now, MappingProxyType(data))
            )
