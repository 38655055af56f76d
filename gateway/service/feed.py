"""The one numbered stream WebSocket clients read: state changes and service events.

The feed subscribes to the ``StateCache``'s changes and to ``ServiceEvents`` and turns each
change into a message with the feed's own sequence number (``seq``, one counter for
everything, so a client needs one number to resume) and ``time``: the wall clock, seconds
since the epoch (float), when the feed published it. Every message is encoded to JSON once,
however many clients get it, and kept in a bounded replay ring (``ws.replay`` messages and at most
``REPLAY_BYTES`` of their text): the gateway's one replay; a client resumes from the number it
last saw, or gets a snapshot when the ring lost some.

Topics: ``axis:<id>`` (``loop.body.motor``), ``controller:<id>`` (``loop.body``),
``loop:<name>``, ``axis:*``, ``controller:*``, ``loop:*``, ``events`` (every event) and
``event:<kind>``. A client may name axes and controllers by name; the feed answers with ids.
An event about a resource (its ``topic``, e.g. an operation on ``axis:main.1.1``) also goes
to the subscribers of that resource.

A state change is published as the resource's whole new view (``gateway.service.views``),
with ``changed`` naming the view's fields that moved; a change that moves nothing a client
sees (the cache's raw flags) is not published at all.

Each client has a bounded queue (``ws.backlog`` messages). Publishing is synchronous: one
``put_nowait`` a matching client, nothing awaited; a client whose queue is full is dropped
(``FeedClient.dropped``, ``ended`` set) and never slows the feed or the other clients.
"""

from __future__ import annotations

import asyncio
import secrets
import time
from collections import deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel
from pydantic_core import to_json

from gateway.bus.state import StateCache
from gateway.bus.state_types import Change
from gateway.errors import InvalidInputError, NotFoundError
from gateway.rings import BoundedRing
from gateway.service.config import WsSettings
from gateway.service.control import ControlStates
from gateway.service.events import EventKind, ServiceEvent, ServiceEvents
from gateway.service.topology import Topology
from gateway.service.views import axis_view, controller_view, loop_view
from gateway.transport.usb_latency import AdapterReport

__all__ = ["REPLAY_BYTES", "TOPIC_RULE", "Feed", "FeedClient", "FeedMessage"]

#: bytes of JSON text the replay ring keeps at most: a loop of 15 controllers publishing
#: views of some 700 bytes would otherwise hold ``ws.replay`` of them whatever their size
REPLAY_BYTES = 4 * 1024 * 1024

TOPIC_RULE = (
    "a topic is axis:<id|name>, controller:<id|name>, loop:<name>, axis:*, controller:*, "
    "loop:*, events or event:<kind> (kinds: " + ", ".join(k.value for k in EventKind) + ")"
)
_WILDCARDS = ("axis:*", "controller:*", "loop:*")


@dataclass(frozen=True, slots=True)
class FeedMessage:
    """One numbered message: the keys it matches (topics, wildcards) and its JSON text."""

    seq: int
    keys: tuple[str, ...]
    text: str


def _default(value: Any) -> Any:
    """JSON for what ``to_json`` does not know (event data from other layers)."""
    if isinstance(value, Mapping):
        return dict(value)
    if isinstance(value, set | frozenset):
        return sorted(value, key=str)
    return str(value)


def _text_size(message: FeedMessage) -> int:
    return len(message.text)


def encode(message: Mapping[str, Any]) -> str:
    """A server message as JSON text."""
    return to_json(message, fallback=_default).decode()


class FeedClient:
    """One reader: its topics and a bounded queue of encoded messages (``await get()``)."""

    def __init__(self, feed: Feed, backlog: int) -> None:
        self._feed = feed
        # A deque and one future rather than an asyncio.Queue: put is an append, and the
        # sender that drains several messages in a row creates no future per message.
        self._queue: deque[str] = deque()
        self._waiter: asyncio.Future[None] | None = None
        self.backlog = backlog
        self.topics: set[str] = set()
        #: True once the queue overflowed: the client is off the feed (close it, 4008)
        self.dropped = False
        #: set when the client is off the feed: dropped, closed, or the feed closed
        self.ended = asyncio.Event()
        #: writes a message to the client's socket at once, or answers False (then it is
        #: queued); set by the transport (gateway.api.ws.direct), None: always queue
        self.direct: Callable[[str], bool] | None = None
        #: True while the sender writes a message it took from the queue
        self.sending = False

    @property
    def pending(self) -> int:
        """Messages queued, not yet taken by ``get``."""
        return len(self._queue)

    def put(self, text: str) -> bool:
        """Queue one message without waiting; False (and the client dropped) when full."""
        if self.ended.is_set():
            return False
        # Straight to the socket when nothing is ahead of it: no task switch per client.
        direct = self.direct
        if direct is not None and not self._queue and not self.sending and direct(text):
            return True
        if len(self._queue) >= self.backlog:
            self.dropped = True
            self._feed._remove(self, dropped=True)
            return False
        self._queue.append(text)
        waiter = self._waiter
        if waiter is not None and not waiter.done():
            waiter.set_result(None)
        return True

    async def get(self) -> str:
        """The next message's JSON text, in feed order."""
        while not self._queue:
            self._waiter = asyncio.get_running_loop().create_future()
            try:
                await self._waiter
            finally:
                self._waiter = None
        return self._queue.popleft()

    def get_nowait(self) -> str | None:
        """The next message's JSON text, None when nothing is queued."""
        return self._queue.popleft() if self._queue else None

    def subscribe(
        self, topics: Iterable[str], since: int | None = None, stream: str | None = None
    ) -> list[str]:
        """Add ``topics``: what they missed since ``since`` then ``subscribed``, or a
        ``snapshot``; live messages follow. Returns the topics as ids."""
        return self._feed._subscribe(self, list(topics), since, stream)

    def unsubscribe(self, topics: Iterable[str]) -> list[str]:
        """Stop the messages of ``topics`` (as ids; a topic not subscribed is ignored)."""
        names = [self._feed.resolve(t, f"topics[{i}]") for i, t in enumerate(topics)]
        self.topics.difference_update(names)
        return names

    def reply(self, message: Mapping[str, Any]) -> bool:
        """Queue a message of the connection's own (pong, error...) with ``seq`` and
        ``time``: seq is the feed's latest number, every message before it already queued."""
        return self.put(encode({**message, "seq": self._feed.seq, "time": self._feed.now()}))

    def close(self) -> None:
        """Leave the feed."""
        self._feed._remove(self, dropped=False)


class Feed:
    """Numbers state changes and service events, keeps the last ones, fans them out."""

    def __init__(
        self,
        topology: Topology,
        cache: StateCache,
        events: ServiceEvents | None = None,
        settings: WsSettings | None = None,
        *,
        clock: Callable[[], float] = time.time,
        control: ControlStates | None = None,
        loop_baud: Callable[[str], int] | None = None,
        loop_adapter: Callable[[str], AdapterReport | None] | None = None,
    ) -> None:
        self.topology, self.cache = topology, cache
        #: the controllers' control state, shown in controller and axis views
        self.control = control or ControlStates(topology)
        #: a loop's rate now (it changes with ``POST /loops/{loop}/baud``); None: configured
        self._loop_baud = loop_baud
        #: what the last open found out about a loop's local adapter; None: nothing known
        self._loop_adapter = loop_adapter
        self.settings = settings or WsSettings()
        self._clock = clock
        self.seq = 0
        #: changes with this feed's numbers; a client resuming from another stream (the
        #: gateway restarted) gets a snapshot
        self.stream = secrets.token_hex(4)
        self._ring: BoundedRing[FeedMessage] = BoundedRing(
            self.settings.replay, REPLAY_BYTES, _text_size
        )
        self._clients: set[FeedClient] = set()
        self.dropped = 0  # clients dropped for a full queue, since start
        self._views: dict[str, dict[str, Any]] = {}
        for topic in self._all_topics():
            self._views[topic] = self._view(topic)
        self._unlisten = [cache.changes.subscribe(self._on_change)]
        if events is not None:
            self._unlisten.append(events.subscribe(self._on_event))

    # ------------------------------------------------------------------ clients

    def now(self) -> float:
        """The wall clock as messages carry it."""
        return round(self._clock(), 6)

    @property
    def clients(self) -> int:
        """Clients on the feed now."""
        return len(self._clients)

    @property
    def replay_kept(self) -> tuple[int, int]:
        """Messages in the replay ring and the bytes of their text."""
        return len(self._ring), self._ring.nbytes

    def backlogs(self) -> list[int]:
        """Each client's messages queued and not yet sent (a slow reader's grows)."""
        return [client.pending for client in self._clients]

    def open(self, backlog: int | None = None) -> FeedClient:
        """A new client with no topics yet."""
        client = FeedClient(self, backlog or self.settings.backlog)
        self._clients.add(client)
        return client

    def subscribe(self, topics: Iterable[str], since: int | None = None) -> FeedClient:
        """A new client subscribed to ``topics`` (see ``FeedClient.subscribe``)."""
        client = self.open()
        try:
            client.subscribe(topics, since)
        except Exception:
            client.close()
            raise
        return client

    def close(self) -> None:
        """Stop listening; every client ends (its connection closes)."""
        for unlisten in self._unlisten:
            unlisten()
        for client in list(self._clients):
            self._remove(client, dropped=False)

    def _remove(self, client: FeedClient, *, dropped: bool) -> None:
        if client in self._clients:
            self._clients.discard(client)
            self.dropped += dropped
        client.ended.set()

    # ------------------------------------------------------------------ topics

    def resolve(self, topic: str, field: str = "topic") -> str:
        """``topic`` with ids for names; ``InvalidInputError`` naming ``field`` otherwise."""
        kind, _, ident = topic.partition(":")
        try:
            if topic in ("events", *_WILDCARDS):
                return topic
            if kind == "event" and ident in {k.value for k in EventKind}:
                return topic
            if kind == "axis" and ident:
                return f"axis:{self.topology.axis(ident).id}"
            if kind == "controller" and ident:
                return f"controller:{self.topology.controller(ident).id}"
            if kind == "loop" and ident:
                return f"loop:{self.topology.loop(ident).name}"
        except NotFoundError as exc:
            raise InvalidInputError(str(exc), field=field, rule=TOPIC_RULE) from None
        raise InvalidInputError(f"unknown topic {topic!r}", field=field, rule=TOPIC_RULE)

    def _all_topics(self) -> list[str]:
        return [
            *(f"loop:{loop.name}" for loop in self.topology.loops()),
            *(f"controller:{c.id}" for c in self.topology.controllers()),
            *(f"axis:{a.id}" for a in self.topology.axes()),
        ]

    def _view(self, topic: str) -> dict[str, Any]:
        kind, _, ident = topic.partition(":")
        view: BaseModel
        if kind == "axis":
            ref = self.topology.axis(ident)
            ctl = self.topology.controller(ref.controller_id)
            control = self.control.view(ctl)
            view = axis_view(ref, self.cache.axis(ref.loop, ref.body, ref.motor), control)
        elif kind == "controller":
            ctl = self.topology.controller(ident)
            control = self.control.view(ctl)
            view = controller_view(ctl, self.cache.controller(ctl.loop, ctl.body), control)
        else:
            loop = self.topology.loop(ident)
            port, baud = loop.settings.port, loop.settings.baud
            if self._loop_baud is not None:
                baud = self._loop_baud(loop.name)
            adapter = self._loop_adapter(loop.name) if self._loop_adapter is not None else None
            state = self.cache.loop(ident)
            view = loop_view(loop.name, port, baud, list(loop.bodies), state, adapter)
        return view.model_dump(mode="json")

    # ------------------------------------------------------------------ subscribing

    def _subscribe(
        self, client: FeedClient, topics: list[str], since: int | None, stream: str | None
    ) -> list[str]:
        names = [self.resolve(t, f"topics[{i}]") for i, t in enumerate(topics)]
        new = {n for n in names if n not in client.topics}
        missed = None if stream not in (None, self.stream) else self._missed(new, since)
        # Room for the missed ones and the acknowledgement, or a snapshot is shorter.
        if missed is not None and len(missed) < client.backlog - client.pending:
            for message in missed:
                client.put(message.text)
            client.topics |= new
            ack = {"type": "subscribed", "topics": sorted(new), "replayed": len(missed)}
            client.reply({**ack, "stream": self.stream})
        else:
            client.topics |= new
            client.reply(self._snapshot(new))
        return names

    def _missed(self, topics: set[str], since: int | None) -> list[FeedMessage] | None:
        """The messages of ``topics`` after ``since``; None when the ring lost some."""
        if since is None or since > self.seq or since < 0:
            return None
        oldest = self._ring[0].seq if self._ring else self.seq + 1
        if since + 1 < oldest:
            return None
        return [m for m in self._ring if m.seq > since and not topics.isdisjoint(m.keys)]

    def _snapshot(self, topics: set[str]) -> dict[str, Any]:
        every = self._all_topics()
        wanted = [t for t in every if t in topics or f"{t.partition(':')[0]}:*" in topics]
        views: dict[str, list[dict[str, Any]]] = {"loops": [], "controllers": [], "axes": []}
        plural = {"loop": "loops", "controller": "controllers", "axis": "axes"}
        for topic in wanted:
            views[plural[topic.partition(":")[0]]].append(self._view(topic))
        return {"type": "snapshot", "topics": sorted(topics), "stream": self.stream, **views}

    # ------------------------------------------------------------------ publishing

    def _on_change(self, change: Change) -> None:
        if change.body is None:
            topic = f"loop:{change.loop}"
        elif change.motor is None:
            topic = f"controller:{change.loop}.{change.body}"
        else:
            topic = f"axis:{change.loop}.{change.body}.{change.motor}"
        self._refresh(topic, change.seq)

    def _refresh(self, topic: str, state_seq: int) -> None:
        """Publish ``topic``'s view when what a client sees of it moved."""
        last = self._views.get(topic)
        if last is None:  # not a configured resource: nobody can subscribe to it
            return
        view = self._view(topic)
        changed = [k for k, v in view.items() if last.get(k) != v]
        if not changed:  # only the cache's raw flags moved, nothing a client sees
            return
        self._views[topic] = view
        kind = topic.partition(":")[0]
        body = {"type": "change", "topic": topic, "state_seq": state_seq, "changed": changed}
        self._publish((topic, f"{kind}:*"), {**body, "data": view})

    def _on_event(self, event: ServiceEvent) -> None:
        if event.kind is EventKind.CONTROL:
            # The views that show the control state change first, then the event says why.
            controller = str(event.data.get("controller"))
            axes = [str(a) for a in event.data.get("axes", ())]
            for topic in (f"controller:{controller}", *(f"axis:{a}" for a in axes)):
                self._refresh(topic, self.cache.seq)
        elif event.kind is EventKind.ORIGIN:  # the axis's view changes first, then the event
            self._refresh(f"axis:{event.data.get('axis')}", self.cache.seq)
        kind = str(event.kind)
        topic = f"event:{kind}"
        body = {"type": "event", "topic": topic, "kind": kind, "resource": event.topic}
        self._publish(("events", topic, event.topic), {**body, "data": dict(event.data)})

    def _publish(self, keys: tuple[str, ...], body: dict[str, Any]) -> None:
        self.seq += 1
        text = encode({"seq": self.seq, "time": self.now(), **body})
        message = FeedMessage(self.seq, keys, text)
        self._ring.append(message)
        for client in list(self._clients):
            if not client.topics.isdisjoint(keys):
                client.put(text)
