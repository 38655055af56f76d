"""Method calls off the connection's request loop: a slow call never holds up a session.

asyncua's server handles the requests of one connection strictly one after the other: it
awaits each service before it decodes the next message. A ``Call`` of a motion method waits
for its audit entry to be written ahead and for the line to accept the motion (tens of
milliseconds at 9600 bps, more while the line is busy), so a client that sends a batch of
calls (a move of every axis of a cell) held its own session for seconds: its reads, its
``Publish`` requests and the keep-alive read that a client uses to see whether the server is
still there all waited behind the calls. Notifications stopped, and asyncua's client, whose
keep-alive read gives up after one second, declared the connection lost (``BadShutdown``).

Here a ``Call`` request is handed to a task of its own and the connection goes on at once with
the next message. The calls of one connection still run one after the other, in the order they
came: a client that sends a move and then a stop without waiting for the move's answer gets
the stop after the move, never the move after the stop. OPC 10000-4 §5.12.2 lets a server
process requests in any order; this one keeps the order of the calls among themselves and
lets everything else (reads, browses, subscriptions, publishing) pass them.

A stop does not wait behind the calls before it: a ``Call`` whose methods are all ``Stop``
waits only for the call running at its arrival (so a move already on its way to the line is
on the wire before the stop, never after it), and the calls it overtook that have not started
are refused when their turn comes if the stop covers them (``stopped_since_queued``: a motion
of an axis of the stopped controller or loop; ``Methods.call`` asks it). A client that sends
45 moves and then a stop on one session stops the machine after at most one move, not after
all of them; the calls that came after the stop wait for it.

A connection may have at most ``MAX_PENDING`` calls waiting; beyond that its request loop
waits for the oldest to end (the flood costs its sender, not the others). A call whose session
was closed by the time its turn comes is refused as any request without a session is; one
whose connection has closed is dropped without acting (nobody would see its answer), as
asyncua dropped the requests still queued on a lost connection.
"""

from __future__ import annotations

import asyncio
import logging
from collections import deque
from collections.abc import Awaitable, Callable
from contextvars import ContextVar
from typing import Any

from asyncua import ua
from asyncua.server.uaprocessor import UaProcessor
from asyncua.ua.ua_binary import nodeid_from_binary, struct_from_binary

__all__ = ["MAX_PENDING", "install_call_lanes", "pending_calls", "stopped_since_queued"]

log = logging.getLogger("gateway.opcua")

#: Calls one connection may have waiting before its request loop waits for the oldest.
MAX_PENDING = 256

_CALL = ua.NodeId(ua.ObjectIds.CallRequest_Encoding_DefaultBinary)
_LANE = "_rc233_call_lane"
_WAITING = "_rc233_overtaken"
#: The method name whose calls overtake the calls waiting before them.
_STOP = "/Stop"

#: In a call's task: the objects of the stops that overtook it while it waited (an axis, a
#: controller or ``loop:<name>``: the ids their ``Stop`` methods belong to).
_overtaken_by: ContextVar[tuple[str, ...]] = ContextVar("rc233_overtaken_by", default=())

#: Every call task not yet ended, so that none is collected while it runs.
_running: set[asyncio.Task[None]] = set()
_installed = False


def pending_calls() -> set[asyncio.Task[None]]:
    """The call tasks still running (the face waits for them when it stops)."""
    return set(_running)


def stopped_since_queued(axis: str) -> str | None:
    """In a method call: the object of a ``Stop`` that its connection sent after this call and
    that overtook it while it waited, if that stop covers ``axis`` (``loop.body.motor``): the
    axis, its controller, another axis of that controller (a stop acts on the controller), or
    its loop. None when there is none."""
    controller = axis.rsplit(".", 1)[0]
    loop = controller.rsplit(".", 1)[0]
    for target in _overtaken_by.get():
        if target in (controller, f"loop:{loop}") or target.rsplit(".", 1)[0] == controller:
            return target
    return None


def _stop_targets(body: Any) -> list[str] | None:
    """The objects a ``Call`` request stops when all its methods are ``Stop``; else None."""
    try:
        buf = body.copy()
        nodeid_from_binary(buf)
        struct_from_binary(ua.RequestHeader, buf)
        methods = struct_from_binary(ua.CallParameters, buf).MethodsToCall
    except Exception:  # asyncua's own decoding answers a malformed request
        return None
    ids = [m.MethodId.Identifier for m in methods]
    if not ids or not all(isinstance(i, str) and i.endswith(_STOP) for i in ids):
        return None
    return [i.removesuffix(_STOP) for i in ids]


def _lane(processor: UaProcessor) -> deque[asyncio.Task[None]]:
    lane: deque[asyncio.Task[None]] | None = getattr(processor, _LANE, None)
    if lane is None:
        lane = deque()
        setattr(processor, _LANE, lane)
    return lane


def _overtaken(processor: UaProcessor) -> dict[asyncio.Task[None], list[str]]:
    """Per call task of the connection, the objects of the stops that overtook it."""
    table: dict[asyncio.Task[None], list[str]] | None = getattr(processor, _WAITING, None)
    if table is None:
        table = {}
        setattr(processor, _WAITING, table)
    return table


def install_call_lanes() -> None:
    """Run ``Call`` requests on a lane of their own per connection (once a process)."""
    global _installed
    if _installed:
        return
    original: Callable[[UaProcessor, Any, Any], Awaitable[bool]] = UaProcessor.process_message

    async def process_message(self: UaProcessor, seqhdr: Any, body: Any) -> bool:
        if nodeid_from_binary(body.copy()) != _CALL:
            return await original(self, seqhdr, body)
        lane = _lane(self)
        while len(lane) >= MAX_PENDING:
            await asyncio.wait([lane[0]])
        stopping = _stop_targets(body)
        overtaken = _overtaken(self)
        if stopping is not None:
            # Only the call at the head of the lane (running, or about to) goes before the
            # stop; the waiting ones are refused at their turn if it covers them
            # (``stopped_since_queued``), or run beside it.
            for waiting in list(lane)[1:]:
                overtaken[waiting].extend(stopping)
            before = [lane[0]] if lane else []
        else:
            before = list(lane)
        stops: list[str] = []

        async def run() -> None:
            if before:
                await asyncio.wait(before)  # their outcomes are their own; only their ends matter
            _overtaken_by.set(tuple(stops))
            if self._transport.is_closing():
                # The client is gone: it would never see the answer and may try elsewhere,
                # so a call that has not started does not act (one that has runs to its end).
                log.warning("opcua: a method call dropped, its connection closed before its turn")
                return
            try:
                if not await original(self, seqhdr, body):
                    self._transport.close()  # as the request loop does when told to close
            except Exception:  # asyncua answers service errors itself; anything else: log
                log.exception("opcua: a method call failed")

        task = asyncio.create_task(run())
        lane.append(task)
        overtaken[task] = stops
        _running.add(task)

        def ended(done: asyncio.Task[None]) -> None:
            _running.discard(done)
            overtaken.pop(done, None)
            if lane and lane[0] is done:
                lane.popleft()
            elif done in lane:
                lane.remove(done)

        task.add_done_callback(ended)
        return True

    UaProcessor.process_message = process_message
    _installed = True
