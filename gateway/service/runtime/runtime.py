"""The running gateway: one scheduler and poller per configured loop, one state cache for all.

``Runtime(config, transports=...)`` builds nothing that touches a port; ``await start()``
opens every loop (one attempt each; a loop that cannot open now keeps trying in the
background, and requests to it fail with ``LoopDown`` meanwhile) and starts polling;
``await close()`` stops accepting, lets the transaction in flight on each loop finish,
closes the ports and then the state store (``store``: the state directory's database, opened
by the owner of the process; in memory when none is given).

The transports come from whoever owns the process, one per loop (``transports``): the command
line opens the configured ports (``gateway.cli.serve.open_lines``) or puts the in-process
simulator behind a loop; this layer never opens a port of its own choosing.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Mapping
from types import MappingProxyType

from gateway.bus.config import LoopConfig
from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import BusEvent, LinkDown, LinkUp, UnsolicitedMessage
from gateway.bus.poll_plan import PollConfig
from gateway.bus.poller import Poller, attach
from gateway.bus.scheduler import LinkState, LoopScheduler
from gateway.bus.state import StateCache
from gateway.protocol.framing import Series
from gateway.protocol.reply_parser import UnsolicitedKind
from gateway.service.config import GatewayConfig, LoopSettings
from gateway.service.control import ControlStates
from gateway.service.events import EventKind, ServiceEvent, ServiceEvents
from gateway.service.runtime.key_switch import KeySwitchReader
from gateway.service.store.database import StateStore
from gateway.service.topology import LoopRef, Topology
from gateway.transport.base import Transport

__all__ = ["Runtime", "loop_config", "poll_config"]

log = logging.getLogger("gateway.service")

#: Real seconds ``close`` lets a transaction in flight finish.
DRAIN_SECONDS = 5.0


def loop_config(settings: LoopSettings, ref: LoopRef, time_scale: float) -> LoopConfig:
    """The scheduler's configuration of one loop."""
    return LoopConfig(
        name=settings.name,
        baud=settings.baud,
        time_scale=time_scale,
        **settings.timeouts.model_dump(),  # TimeoutSettings' fields are LoopConfig's
        sum_at_connect=settings.sum_at_connect,
        series=MappingProxyType(
            {c.body: c.series for c in ref.controllers if c.series is not Series.DOLLAR}
        ),
    )


def poll_config(settings: LoopSettings) -> PollConfig:
    """The poller's periods of one loop."""
    return PollConfig(**settings.poll.model_dump())  # PollSettings' fields are PollConfig's


class Runtime:
    """The running gateway: every loop of a configuration, its state cache, service events,
    control states and key switch reader (what the faces are built on)."""

    def __init__(
        self,
        config: GatewayConfig,
        *,
        transports: Mapping[str, Transport],
        time_scale: float = 1.0,
        store: StateStore | None = None,
    ) -> None:
        self.config = config
        #: what must outlive the process (operations, idempotency keys, counters); in memory
        #: unless the owner of the process opened the state directory's
        self.store = store if store is not None else StateStore.memory()
        self.topology = Topology(config)
        self.state = StateCache()
        self.events = ServiceEvents()
        self.time_scale = time_scale
        self.schedulers: dict[str, LoopScheduler] = {}
        self.pollers: dict[str, Poller] = {}
        self.started = time.time()
        transports = dict(transports)
        missing = [ref.name for ref in self.topology.loops() if ref.name not in transports]
        if missing:
            raise ValueError(f"no transport for the loops {missing}")
        for ref in self.topology.loops():
            settings = ref.settings
            transport = transports.pop(ref.name)
            scheduler = LoopScheduler(transport, loop_config(settings, ref, time_scale))
            self.schedulers[ref.name] = scheduler
            self.pollers[ref.name] = attach(
                scheduler, self.state, ref.bodies, poll_config(settings)
            )
            scheduler.events.subscribe(self._relay)
        #: local/remote control of every controller, and the key switches' reader
        self.control = ControlStates(self.topology, self.events)
        self.key_switches = KeySwitchReader(self.topology, self.control, self.schedulers)
        if transports:
            raise ValueError(f"transports for loops not configured: {sorted(transports)}")

    # ------------------------------------------------------------------ life

    async def start(self) -> None:
        """Open every loop (one attempt each) and start polling."""
        await asyncio.gather(*(s.start() for s in self.schedulers.values()))
        for name, poller in self.pollers.items():
            poller.start()
            scheduler = self.schedulers[name]
            if scheduler.state is not LinkState.UP:
                log.warning("loop %s is not up yet: %s", name, scheduler.cause)
        self.key_switches.start()

    async def close(self, *, drain: float = DRAIN_SECONDS) -> None:
        """Stop polling, let each loop's transaction in flight finish, close the ports."""
        await self.key_switches.stop()
        await asyncio.gather(*(p.stop() for p in self.pollers.values()))
        await asyncio.gather(*(s.close(drain=drain) for s in self.schedulers.values()))
        await self.store.close()  # last: the ends of the operations drained above are written

    # ------------------------------------------------------------------ reading

    def scheduler(self, loop: str) -> LoopScheduler:
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
