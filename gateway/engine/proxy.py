"""The API process's end: a scheduler's calling surface, carried over a worker's channels.

``WorkerClient(name, loops, mirror)`` attaches to a worker's two channels (``attach``) and
offers one ``SchedulerProxy`` per loop (``proxies``): ``submit`` and ``stop`` send a request
and await the reply; ``state``, ``cause`` and ``events`` follow the worker's bus events; the
state cache is the ``StateMirror`` the client feeds, so reading state never crosses the
channel. Stops go on the stop channel, which the worker reads first.

When the worker goes away (``detach``, or its channel closes), every request waiting for a
reply fails with ``LoopDown`` naming the cause (``in_flight``: the commands may have been
sent), every loop of the worker is down with that cause until a worker attaches again, and
requests meanwhile fail at once with ``LoopDown`` carrying the retry hint. The latches the
mirror showed for them are held there (``StateMirror.hold``): a worker's death acknowledges
nothing.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import time
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from gateway.bus.config import LoopConfig
from gateway.bus.counters import CountersSnapshot
from gateway.bus.events import (
    BusEvent,
    EventBus,
    LinkDown,
    LinkUp,
    TransactionDone,
    TransactionsTallied,
)
from gateway.bus.lifecycle import LinkState
from gateway.bus.requests import LoopDown, Priority, TransactionResult
from gateway.bus.state_types import Change, ErrorKind
from gateway.engine.mirror import StateMirror
from gateway.engine.scheduler_reads import PollerProxy, RemoteLine, RemoteTrace
from gateway.engine.wire import Channel, Kind, decode_error, encode, read_message
from gateway.protocol.models import Command
from gateway.protocol.program import Program

__all__ = ["SchedulerProxy", "WorkerClient"]

log = logging.getLogger("gateway.engine")


class SchedulerProxy:
    """One loop of a worker, as service/ calls a ``LoopScheduler``."""

    def __init__(self, client: WorkerClient, name: str, config: LoopConfig | None = None) -> None:
        self.client = client
        self.name = name
        #: the scheduler's configuration in the worker (``time_scale`` among it)
        self.config = config if config is not None else LoopConfig(name=name)
        self.state = LinkState.CONNECTING
        self.cause = "the line worker is not connected yet"
        self.events: EventBus[BusEvent] = EventBus()
        #: host seconds from now when the worker is expected back (None: not known)
        self.retry_after: float | None = None
        #: requests queued in the worker's scheduler, as of its latest event
        self.queue_depth = 0
        #: the loop's counters as of its latest transaction (``snapshot()``)
        self.counters = CountersSnapshot()
        #: the line's rate and adapter report as the worker last opened it
        self.line = RemoteLine(self.config.baud or 9600)
        #: the loop's trace: switched here and in the worker, fed by the worker's records
        self.trace = RemoteTrace(self._trace_switches, self.config.trace_size)

    @staticmethod
    def clock() -> float:
        """The host's clock, the schedulers' (``time.monotonic``: one clock for every process
        of the host, so the worker's times read the same here)."""
        return time.monotonic()

    @property
    def timing(self) -> RemoteLine:
        """The line's rate as ``timing.baud`` (a scheduler's word for it)."""
        return self.line

    @property
    def transport(self) -> RemoteLine:
        """The adapter report as ``transport.adapter`` (a scheduler's word for it)."""
        return self.line

    def _trace_switches(
        self, everything: bool, bodies: tuple[str, ...], hex_mode: bool, clear: bool
    ) -> None:
        self.client.tell((Kind.TRACE, self.name, everything, bodies, hex_mode, clear))

    async def submit(
        self,
        body: str,
        commands: Command | Sequence[Command],
        *,
        priority: Priority = Priority.OPERATOR,
        motor: int | None = None,
        deadline: float | None = None,
    ) -> TransactionResult:
        """Run ``commands`` on controller ``body`` in the worker (``LoopScheduler.submit``)."""
        cmds = (commands,) if isinstance(commands, Command) else tuple(commands)
        message = (Kind.SUBMIT, self.name, body, cmds, priority, motor, deadline)
        result: TransactionResult = await self.client.request(self.name, message)
        return result

    async def stop(self, body: str, command: Command | None = None) -> TransactionResult:
        """Send a stop on the stop channel (``LoopScheduler.stop``)."""
        message = (Kind.STOP, self.name, body, command)
        result: TransactionResult = await self.client.request(self.name, message, urgent=True)
        return result

    async def upload_program(
        self,
        body: str,
        program: Program,
        *,
        priority: Priority = Priority.OPERATOR,
        deadline: float | None = None,
    ) -> TransactionResult:
        """Upload ``program`` in the worker (``LoopScheduler.upload_program``)."""
        message = (Kind.UPLOAD, self.name, body, program, priority, deadline)
        result: TransactionResult = await self.client.request(self.name, message)
        return result

    def reopen_at(self, baud: int) -> None:
        """Reopen the worker's line at ``baud`` (``LoopScheduler.reopen_at``): the link's
        loss and return come back as events."""
        self.line.baud = baud  # as a scheduler's timing: at once, whatever the line does
        self.client.tell((Kind.REOPEN, self.name, baud))

    async def polling(self, on: bool) -> None:
        """Start or stop the loop's poller in the worker (stopped: no poll in flight)."""
        await self.client.request(self.name, (Kind.POLLING, self.name, on))

    def snapshot(self) -> CountersSnapshot:
        """The loop's counters as of its latest transaction in the worker."""
        return self.counters

    def down_error(self) -> LoopDown:
        """The error of a request refused because the loop is not up."""
        return LoopDown(self.name, self.cause, retry_after=self.retry_after)


class WorkerClient:
    """The channels to one worker, and the proxies of its loops."""

    def __init__(
        self,
        name: str,
        loops: Iterable[str],
        mirror: StateMirror,
        configs: Mapping[str, LoopConfig] | None = None,
    ) -> None:
        self.name = name
        self.mirror = mirror
        configs = configs or {}
        self.proxies = {loop: SchedulerProxy(self, loop, configs.get(loop)) for loop in loops}
        #: each loop's poller, switched by requests
        self.pollers = {
            loop: PollerProxy(loop, proxy.polling) for loop, proxy in self.proxies.items()
        }
        for loop in self.proxies:
            mirror.route(loop, self._acknowledge)
        #: the controllers whose reply events the worker relays (None: all)
        self.followed: frozenset[tuple[str, str]] | None = None
        self._ids = itertools.count(1)
        self._waiting: dict[int, tuple[str, asyncio.Future[Any]]] = {}
        self._writers: tuple[asyncio.StreamWriter, asyncio.StreamWriter] | None = None
        self._readers: list[asyncio.Task[None]] = []
        #: set when the first snapshot of the current attachment is in
        self.synced = asyncio.Event()

    @property
    def attached(self) -> bool:
        """True while a worker's channels are attached."""
        return self._writers is not None

    async def attach(self, requests: Channel, stops: Channel) -> None:
        """Take a (new) worker's channels and read them until they close."""
        if self._writers is not None:  # else its loops are down with the cause of its end
            await self.detach("a new worker attached")
        self.synced.clear()
        self._writers = (requests[1], stops[1])
        self._readers = [
            asyncio.create_task(self._read(requests[0])),
            asyncio.create_task(self._read(stops[0])),
        ]

    async def detach(self, cause: str, *, retry_after: float | None = None) -> None:
        """Let go of the worker's channels: its loops are down with ``cause``."""
        writers, self._writers = self._writers, None
        readers, self._readers = self._readers, []
        # Said before anything is awaited: the supervisor's word on how the worker ended
        # (with its retry hint) may come while a reader that saw the channel close is still
        # here, and must stay the last word, not be overwritten by this one.
        self._gone(cause, retry_after)
        current = asyncio.current_task()
        for task in readers:
            if task is not current:
                task.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await task
        if writers is not None:
            for writer in writers:
                writer.close()

    def follow(self, controllers: frozenset[tuple[str, str]]) -> None:
        """Have the worker relay the reply events of ``controllers`` (loop, body) only: the
        ones an operation watches. A new worker is told again when it attaches."""
        self.followed = controllers
        self.tell((Kind.FOLLOW, controllers))

    def _acknowledge(
        self, loop: str, body: str, motor: int | None, kinds: tuple[ErrorKind, ...] | None
    ) -> None:
        # no answer awaited: the mirror cleared its record already, the worker's change
        # follows; a worker away now has nothing to clear (its successor starts unlatched)
        self.tell((Kind.ACKNOWLEDGE, loop, body, motor, kinds))

    def _gone(self, cause: str, retry_after: float | None) -> None:
        self.mirror.forget(self.name)
        self.mirror.hold(self.proxies)
        now = time.monotonic()
        for loop in self.proxies:
            # as after a line loss: nothing the dead worker read is current, not even that a
            # motor moves; the next worker reads the devices again
            self.mirror.set_link(loop, False, now, cause)
        waiting, self._waiting = self._waiting, {}
        for loop, future in waiting.values():
            if not future.done():
                future.set_exception(LoopDown(loop, cause, in_flight=True))
        for proxy in self.proxies.values():
            # a second word on the same loss (the supervisor learns how the worker ended
            # after its channel closed) is told too: clients see the cause they can act on
            news = proxy.state is LinkState.UP or proxy.cause != cause
            proxy.state, proxy.cause, proxy.retry_after = LinkState.DOWN, cause, retry_after
            if news:
                down = LinkDown(
                    loop=proxy.name, time=time.monotonic(), cause=cause, retry_after=retry_after
                )
                self.mirror.relay(down)
                proxy.events.publish(down)

    def tell(self, message: tuple[Any, ...]) -> None:
        """Send ``message`` on the request channel, no answer awaited (none when detached:
        a new worker starts from its configuration)."""
        if self._writers is not None:
            self._writers[0].write(encode(message))

    async def request(self, loop: str, message: tuple[Any, ...], *, urgent: bool = False) -> Any:
        """Send ``message`` (its kind, then its fields after the request's number) and await
        the worker's answer."""
        writers = self._writers
        if writers is None:
            raise self.proxies[loop].down_error()
        rid = next(self._ids)
        future: asyncio.Future[Any] = asyncio.get_running_loop().create_future()
        self._waiting[rid] = (loop, future)
        writers[1 if urgent else 0].write(encode((message[0], rid, *message[1:])))
        try:
            return await future
        finally:
            self._waiting.pop(rid, None)

    async def _read(self, reader: asyncio.StreamReader) -> None:
        while (message := await read_message(reader)) is not None:
            self._handle(message)
        if self._writers is not None:
            log.warning("line worker %s: its channel closed", self.name)
            await self.detach(f"line worker {self.name} went away")

    def _link_from(self, change: Change) -> None:
        """The loop went up or down, as the worker's cache wrote it: its link event comes as
        a message of its own, after this one (the cache hears the scheduler first), and a
        client told by the change (the WebSocket's loop records) must find the proxy, which
        REST and every request read, saying the same meanwhile."""
        proxy = self.proxies.get(change.loop)
        up = change.values.get("up")
        if proxy is None or up is None:
            return
        if up:
            proxy.state, proxy.cause = LinkState.UP, ""
        elif proxy.state is LinkState.UP:
            proxy.state = LinkState.DOWN
            proxy.cause = str(change.values.get("cause") or "the line went down")

    def _handle(self, message: tuple[Any, ...]) -> None:
        kind = message[0]
        if kind == Kind.CHANGE:
            if message[1].body is None:
                self._link_from(message[1])  # before the mirror tells its followers
            applied = self.mirror.apply(self.name, message[1])
            # a gap (not a change before the snapshot): ask for a snapshot, once
            if not applied and self.mirror.source_seq(self.name) is not None and self._writers:
                self.mirror.forget(self.name)
                self._writers[0].write(encode((Kind.RESYNC,)))
        elif kind == Kind.EVENT:
            _, loop, event, state, cause, depth = message
            proxy = self.proxies[loop]
            proxy.queue_depth = depth
            proxy.state, proxy.cause = LinkState(state), cause
            if isinstance(event, LinkDown):
                proxy.retry_after = event.retry_after
            elif isinstance(event, TransactionDone | TransactionsTallied):
                proxy.counters = event.counters
            self.mirror.relay(event)  # the followers first, as the cache of one process does
            proxy.events.publish(event)
        elif kind == Kind.LINE:
            line = self.proxies[message[1]].line
            line.baud, line.adapter = message[2], message[3]
        elif kind == Kind.TRACED:
            self.proxies[message[1]].trace.take(message[2])
        elif kind == Kind.FRESH:
            self.mirror.freshen(message[1])
        elif kind in (Kind.RESULT, Kind.ERROR):
            entry = self._waiting.pop(message[1], None)
            if entry is not None and not entry[1].done():
                if kind == Kind.RESULT:
                    entry[1].set_result(message[2])
                else:
                    entry[1].set_exception(decode_error(message[2]))
        elif kind == Kind.SNAPSHOT:
            self.mirror.load(self.name, message[1])
            for loop, (state, cause, depth, counters, adapter, baud) in message[2].items():
                proxy = self.proxies[loop]
                was_up = proxy.state is LinkState.UP
                proxy.state, proxy.cause = LinkState(state), cause
                proxy.queue_depth, proxy.counters = depth, counters
                proxy.line.adapter, proxy.line.baud = adapter, baud
                if proxy.trace.on:  # a new worker traces nothing until told
                    proxy.trace.resend()
                if proxy.state is LinkState.UP and not was_up:
                    up = LinkUp(loop=loop, time=time.monotonic())
                    self.mirror.relay(up)
                    proxy.events.publish(up)
            if self.followed is not None:  # nor does it know whose replies to skip
                self.tell((Kind.FOLLOW, self.followed))
            self.synced.set()
