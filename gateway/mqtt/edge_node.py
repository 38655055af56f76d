"""The Sparkplug B edge node: the gateway's state on an MQTT broker (aiomqtt, paho-mqtt 2).

Session: connect with NDEATH as the will (QoS 1, carrying this connection's ``bdSeq``),
subscribe to NCMD (and DCMD when commands are enabled), publish NBIRTH (``seq`` 0) and a
DBIRTH for every controller that is alive, then report by exception: a DDATA with only the
metrics whose value moved, stamped with the device's times; ``seq`` counts every message after
the NBIRTH, 0-255 and round again. A controller whose loop goes down or that stops answering
gets a DDEATH; a DBIRTH when it is back. NCMD ``Node Control/Rebirth`` gives a new NBIRTH and
the DBIRTHs. On shutdown an NDEATH is sent before disconnecting.

The serial loop never waits for the broker (DESIGN invariant 12): the state cache calls
``_on_change`` synchronously, which only marks the controller (or the node) as changed and
wakes the publisher. The queue is thus one mark per device, bounded by the configuration;
changes that come while a publish is under way are coalesced, the newest value wins (counted
in ``MQTT/Superseded``): the drop-oldest policy, without store-and-forward. While the broker
is away nothing is kept; the rebirth after the reconnection carries the state of that moment.

The broker down or restarting: reconnect with exponential back-off (``reconnect_min`` ..
``reconnect_max`` seconds, jittered), ``bdSeq`` + 1, rebirth. ``bdSeq`` is kept in the state
store before each connection, so it goes on across restarts of the process too.

MQTT 5, for what it tells about the session: oversized payloads are dropped unread, a second
node with the same id is detected and backed off from (gateway/mqtt/session_guard.py); with
``primary_host`` the births wait for the host's STATE (gateway/mqtt/primary_host.py).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging

import aiomqtt
from paho.mqtt.subscribeoptions import SubscribeOptions

from gateway.mqtt.broker_client import broker_client, client_id
from gateway.mqtt.dcmd import DeviceCommands
from gateway.mqtt.metric_table import MetricTable, Values, axis_label, changed, device_id, millis
from gateway.mqtt.primary_host import PrimaryHost
from gateway.mqtt.session_guard import Backoff, DuplicateNode, PayloadBound, taken_over
from gateway.mqtt.sparkplug import Message, Metric, Value, decode_commands, encode, topic
from gateway.service.config import MqttSettings
from gateway.service.events import EventKind, ServiceEvent
from gateway.service.runtime.bus_types import (
    BusEvent,
    Change,
    TransactionDone,
    TransactionsTallied,
)
from gateway.service.runtime.runtime import Runtime

__all__ = ["EdgeNode"]

log = logging.getLogger("gateway.mqtt")

#: The state store's counter of the last session's ``bdSeq``.
BD_SEQ_COUNTER = "sparkplug_bdseq"
#: Real seconds the NDEATH of a shutdown may take before the connection is simply dropped.
DEATH_TIMEOUT = 2.0


class HostOffline(Exception):
    """The primary host said it is offline: NDEATH, disconnect, wait for it again."""


class EdgeNode:
    """One gateway as a Sparkplug B edge node; ``await run()`` until cancelled."""

    def __init__(
        self, runtime: Runtime, settings: MqttSettings, *, commands: DeviceCommands | None = None
    ) -> None:
        self.runtime, self.settings = runtime, settings
        self.commands = commands if settings.commands else None
        self.table = MetricTable(
            runtime.topology, runtime.state, commands=self.commands is not None
        )
        self._by_body = {(c.loop, c.body): device_id(c) for c in runtime.topology.controllers()}
        # The next connection's bdSeq follows the last one of any process before (the store).
        self.bd_seq = runtime.store.counters.get(BD_SEQ_COUNTER, -1)
        self.seq = 0
        self.superseded = 0
        self.takeovers = 0
        self.payloads = PayloadBound(settings.max_payload)
        self.primary = PrimaryHost(settings.primary_host) if settings.primary_host else None
        self.connected = asyncio.Event()
        self._wake = asyncio.Event()
        self._dirty: set[str] = set()
        self._node_dirty = False
        self._rebirth = False
        self._node_sent: Values = {}
        self._sent: dict[str, Values] = {}  # device -> what its DBIRTH and DDATAs said
        #: loop -> host seconds its line was held by transactions (measured, as /metrics)
        self.busy: dict[str, float] = {name: 0.0 for name in runtime.schedulers}
        self._busy_mark: dict[str, tuple[float, float]] = {}  # loop -> (busy, host time)
        self._utilisation: dict[str, float | None] = {}
        self._unlisten = [
            runtime.state.changes.subscribe(self._on_change),
            runtime.events.subscribe(self._on_event),
            *(s.events.subscribe(self._on_bus) for s in runtime.schedulers.values()),
        ]

    # ------------------------------------------------------------------ cache -> marks

    def _mark(self, device: str) -> None:
        if device in self._dirty:
            self.superseded += 1
        self._dirty.add(device)
        self._wake.set()

    def _on_change(self, change: Change) -> None:
        """Synchronous, O(1) a change: no I/O, nothing awaited (the scheduler calls it)."""
        if change.body is None:
            self._node_dirty = True
            if "up" in change.values:  # the loop's controllers die or may be born
                for (loop, _), dev in self._by_body.items():
                    if loop == change.loop:
                        self._mark(dev)
            if "counters" in change.values:  # about once a second (StateCache.counters_period)
                self._measure(change.loop, change.time)
            self._wake.set()
            return
        device = self._by_body.get((change.loop, change.body))
        if device is not None:
            self._mark(device)

    def _on_event(self, event: ServiceEvent) -> None:
        """Operations give the axes' targets."""
        if event.kind is not EventKind.OPERATION or not event.topic.startswith("axis:"):
            return
        axis = self.runtime.topology.axis(event.topic.partition(":")[2])
        target = event.data.get("target")
        self.table.targets[axis.id] = target if isinstance(target, int) else None
        self._mark(self._by_body[axis.loop, axis.body])

    def _on_bus(self, event: BusEvent) -> None:
        if isinstance(event, TransactionDone):
            self.busy[event.loop] = self.busy.get(event.loop, 0.0) + event.duration
        elif isinstance(event, TransactionsTallied):  # a worker's idle polls, in bulk
            busy = sum(tally.duration for tally in event.tallies)
            self.busy[event.loop] = self.busy.get(event.loop, 0.0) + busy

    def _measure(self, loop: str, when: float) -> None:
        """Line utilisation since the last counters update: measured busy over elapsed."""
        busy = self.busy.get(loop, 0.0)
        last = self._busy_mark.get(loop)
        self._busy_mark[loop] = (busy, when)
        if last is not None and when > last[1]:
            self._utilisation[loop] = round(min(1.0, (busy - last[0]) / (when - last[1])), 4)

    # ------------------------------------------------------------------ running

    async def run(self) -> None:
        """Connect, publish, reconnect with back-off; until cancelled (NDEATH sent then)."""
        backoff = Backoff(self.settings.reconnect_min, self.settings.reconnect_max)
        try:
            while True:
                self.bd_seq = (self.bd_seq + 1) % 256
                try:
                    await self.runtime.store.set_counter(BD_SEQ_COUNTER, self.bd_seq)
                except Exception as exc:  # the session goes on; a restart may repeat this one
                    log.error("mqtt: bdSeq %d not stored: %s", self.bd_seq, exc)
                try:
                    async with await self._client() as client:
                        backoff.connected()
                        await self._session(client)
                    wait = backoff.next_wait(takeover=False)  # the primary host went offline
                except DuplicateNode as exc:
                    wait = self._duplicate(str(exc), backoff)
                except aiomqtt.MqttError as exc:
                    if taken_over(exc):
                        wait = self._duplicate(
                            "the broker gave our session to another client", backoff
                        )
                    elif backoff.session_lost():
                        what = (
                            f"the broker closed {backoff.short_losses} sessions in a row "
                            "soon after they began, as when another client takes them over"
                        )
                        wait = self._duplicate(what, backoff)
                    else:
                        wait = backoff.next_wait(takeover=False)
                        log.warning(
                            "mqtt: broker %s:%d: %s; again in %.1f s",
                            self.settings.host, self.settings.port, exc, wait,
                        )  # fmt: skip
                except Exception:  # never leave the plant without the node: log, try again
                    wait = backoff.next_wait(takeover=False)
                    log.exception("mqtt: edge node failed; again in %.1f s", wait)
                self.connected.clear()
                await asyncio.sleep(wait)
        finally:
            self.connected.clear()

    def _duplicate(self, what: str, backoff: Backoff) -> float:
        """Another node uses our id: say so loudly, count it, and wait longer each time."""
        self.takeovers += 1
        self._node_dirty = True
        wait = backoff.next_wait(takeover=True)
        log.error(
            "mqtt: %s: edge node %s/%s (client id %s) is used by another node; a Sparkplug "
            "id must be unique (takeover %d; again in %.1f s)",
            what, self.settings.group, self.settings.edge_node, self._client_id(),
            self.takeovers, wait,
        )  # fmt: skip
        return wait

    def _client_id(self) -> str:
        return client_id(self.settings)

    def close(self) -> None:
        """Stop listening to the cache (after ``run`` is cancelled)."""
        for unlisten in self._unlisten:
            unlisten()

    async def _client(self) -> aiomqtt.Client:
        death = self._topic(Message.NDEATH), self._death_payload()
        return await broker_client(self.settings, self._client_id(), death)

    def _death_payload(self) -> bytes:
        spec = self.table.node["bdSeq"]
        bd = Metric("bdSeq", spec.alias, spec.datatype, self.bd_seq, millis())
        return encode([bd], timestamp=millis(), seq=None, birth=True)

    async def _session(self, client: aiomqtt.Client) -> None:
        await client.subscribe(self._topic(Message.NCMD), qos=0)
        if self.commands is not None:
            await client.subscribe(self._topic(Message.DCMD) + "/+", qos=0)
        # Our own NBIRTH never comes back (no-local): one that comes is another node's.
        await client.subscribe(self._topic(Message.NBIRTH), options=SubscribeOptions(noLocal=True))
        if self.primary is not None:
            await client.subscribe(self.primary.topic, qos=1)
        log.info("mqtt: connected to %s:%d as edge node %s/%s (bdSeq %d)",
                 self.settings.host, self.settings.port, self.settings.group,
                 self.settings.edge_node, self.bd_seq)  # fmt: skip
        reader = asyncio.create_task(self._read(client))
        try:
            await self._wait_for_primary_host(reader)
            await self._birth(client)
            self.connected.set()
            while True:
                await self._wake.wait()
                self._wake.clear()
                if reader.done():  # the connection ended under the reader
                    reader.result()
                if self.primary is not None and not self.primary.online:
                    raise HostOffline
                await self._publish_changes(client)
        except HostOffline:
            log.warning("mqtt: primary host %s is offline: NDEATH, disconnect, wait for it",
                        self.settings.primary_host)  # fmt: skip
            await self._death(client)
        except (asyncio.CancelledError, DuplicateNode):
            await self._death(client)
            raise
        finally:
            reader.cancel()
            with contextlib.suppress(BaseException):
                await reader

    async def _death(self, client: aiomqtt.Client) -> None:
        """Publish the NDEATH of this session (then the caller disconnects)."""
        with contextlib.suppress(Exception):
            payload = self._death_payload()
            ndeath = client.publish(self._topic(Message.NDEATH), payload, qos=1)
            await asyncio.wait_for(ndeath, DEATH_TIMEOUT)

    async def _wait_for_primary_host(self, reader: asyncio.Task[None]) -> None:
        """Return once the primary host's STATE says online (at once without one)."""
        if self.primary is None or self.primary.online:
            return
        log.info("mqtt: waiting for primary host %s to be online", self.primary.host_id)
        while not self.primary.online:
            await self._wake.wait()
            self._wake.clear()
            if reader.done():
                reader.result()
                raise aiomqtt.MqttError("the connection ended while waiting for the host")

    def _on_state(self, payload: bytes) -> None:
        assert self.primary is not None
        if self.primary.receive(payload):
            log.info("mqtt: primary host %s %s", self.primary.host_id,
                     "online" if self.primary.online else "offline")  # fmt: skip
            self._wake.set()

    async def _read(self, client: aiomqtt.Client) -> None:
        born = self._topic(Message.NBIRTH)
        try:
            async for message in client.messages:
                payload = message.payload
                if not isinstance(payload, bytes | bytearray):
                    continue
                where = str(message.topic)
                if not self.payloads.allows(where, len(payload)):
                    self._node_dirty = True
                    self._wake.set()
                    continue
                if where == born:
                    raise DuplicateNode(f"an NBIRTH of another node on {where}")
                try:
                    if self.primary is not None and where == self.primary.topic:
                        self._on_state(bytes(payload))
                        continue
                    await self._command(str(message.topic), bytes(payload))
                except ValueError as exc:
                    log.warning("mqtt: %s: %s", message.topic, exc)
                except Exception:  # a command's failure must not end the session
                    log.exception("mqtt: %s failed", message.topic)
        finally:
            self._wake.set()  # the publisher sees the connection's end

    async def _command(self, where: str, payload: bytes) -> None:
        parts = where.split("/")
        if parts[2] == Message.NCMD.value:
            names = {a: n for a, (d, n) in self.table.names.items() if d is None}
            metrics = decode_commands(payload, names)
            if metrics.get("Node Control/Rebirth") is True:
                log.info("mqtt: rebirth asked")
                self._rebirth = True
                self._wake.set()
        elif parts[2] == Message.DCMD.value and self.commands is not None and len(parts) == 5:
            ctl = self.table.controllers.get(parts[4])
            if ctl is None:
                raise ValueError(f"no device {parts[4]!r}")
            names = {a: n for a, (d, n) in self.table.names.items() if d == parts[4]}
            labels = {axis_label(a): a.id for a in ctl.axes}
            await self.commands.handle(where, ctl, labels, decode_commands(payload, names))

    # ------------------------------------------------------------------ publishing

    def _topic(self, message: Message, device: str | None = None) -> str:
        return topic(self.settings.group, message, self.settings.edge_node, device)

    def _next_seq(self) -> int:
        seq = self.seq
        self.seq = (seq + 1) % 256
        return seq

    def _node_values(self) -> Values:
        extra: dict[str, Value] = {
            "MQTT/Superseded": self.superseded,
            "MQTT/Dropped Payloads": self.payloads.dropped,
            "MQTT/Takeovers": self.takeovers,
        }
        for loop in self.runtime.topology.loops():
            extra[f"Loops/{loop.name}/Line Utilisation"] = self._utilisation.get(loop.name)
            extra[f"Loops/{loop.name}/Busy Seconds"] = round(self.busy.get(loop.name, 0.0), 6)
        return self.table.node_values(self.bd_seq, extra)

    async def _send(self, client: aiomqtt.Client, where: str, metrics: list[Metric],
                    *, birth: bool = False) -> None:  # fmt: skip
        payload = encode(metrics, timestamp=millis(), seq=self._next_seq(), birth=birth)
        await client.publish(where, payload, qos=0)

    async def _birth(self, client: aiomqtt.Client) -> None:
        self._rebirth, self._node_dirty, self.seq = False, False, 0
        self._dirty.clear()
        values = self._node_values()
        await self._send(client, self._topic(Message.NBIRTH),
                         self.table.metrics(self.table.node, values), birth=True)  # fmt: skip
        self._node_sent = values
        self._sent.clear()
        for dev in self.table.devices:
            if self.table.alive(dev):
                await self._device_birth(client, dev)

    async def _device_birth(self, client: aiomqtt.Client, dev: str) -> None:
        values = self.table.device_values(dev)
        metrics = self.table.metrics(self.table.devices[dev], values)
        await self._send(client, self._topic(Message.DBIRTH, dev), metrics, birth=True)
        self._sent[dev] = values

    async def _publish_changes(self, client: aiomqtt.Client) -> None:
        if self._rebirth:
            await self._birth(client)
            return
        if self._node_dirty:
            self._node_dirty = False
            values = self._node_values()
            # (MQTT/Superseded goes along when anything else of the node moves: at most ~1/s)
            moved = changed(self._node_sent, values)
            if moved:
                metrics = self.table.metrics(self.table.node, values, moved)
                await self._send(client, self._topic(Message.NDATA), metrics)
                self._node_sent = values
        while self._dirty:
            dev = min(self._dirty)
            self._dirty.discard(dev)
            await self._publish_device(client, dev)

    async def _publish_device(self, client: aiomqtt.Client, dev: str) -> None:
        alive, born = self.table.alive(dev), dev in self._sent
        if alive and not born:
            await self._device_birth(client, dev)
        elif not alive and born:
            del self._sent[dev]
            await self._send(client, self._topic(Message.DDEATH, dev), [])
        elif alive:
            values = self.table.device_values(dev)
            moved = changed(self._sent[dev], values)
            if moved:
                metrics = self.table.metrics(self.table.devices[dev], values, moved)
                await self._send(client, self._topic(Message.DDATA, dev), metrics)
                self._sent[dev] = values
