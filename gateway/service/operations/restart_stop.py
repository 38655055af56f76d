"""The stop of a hold-to-run motion that the last gateway process left running.

A jog (``7``/``8``, §10 7/8; and a jog toward a soft limit, a move to it at the jog speed)
runs until a stop or a limit sensor: it is moving only because someone holds it (the
dashboard's hold-to-jog, a client that ends it with a stop). When the gateway dies, its holder
is gone with it, and the axis would go on alone, possibly into a limit. So at start, once the
axis's loop is up, the gateway stops every jog left in flight with ``SS`` (§10 SS: down to Low
speed, then stop; the stop an operator's release sends, gentler on the mechanics than ``S``).
``S``/``SS`` act on the selected motor, which is the moving one (``F`` is refused while a motor
moves, §10 F), so no selection is sent first.

What is *not* stopped here: an origin search (``home``) has its own end (the origin, or a limit
sensor, §10 0R), and its read-back waits for it; a user program (``G``) is no operation of the
gateway and is left to run (stop it with ``POST /controllers/{id}/program/stop``).

``RestartStop`` is what the attempt did; it goes to the log and, through
``Operations.on_restart_stop``, to the audit log (``audit_entry``).

The same stop ends a jog whose loop went down while it ran (its holder's release could not
reach it through the dead line), once the loop is up again, and a jog whose controller alone
went silent, once it answers again (``line_stop``): one mechanism for "stop the jogs nobody
holds"; the ``Occasion`` says which it was, in the audit, the log and the operation's verdict.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

from gateway.bus.events import LinkUp
from gateway.bus.requests import LoopDown, Outcome
from gateway.bus.scheduler import LinkState
from gateway.protocol import commands as cmd
from gateway.service.operations.types import Operation
from gateway.service.runtime.runtime import Runtime

__all__ = [
    "AT_ANSWER",
    "AT_LINK_UP",
    "AT_RESTART",
    "HOLD_TO_RUN",
    "Occasion",
    "RestartStop",
    "link_up",
    "stop_left_running",
    "tell",
]

log = logging.getLogger("gateway.service")

#: Operation kinds that run only while held: stopped at restart when left in flight.
HOLD_TO_RUN = frozenset({"jog"})
#: Host seconds between the first two attempts at the stop while the loop is up but the stop
#: was lost; doubled after each, up to ``RETRY_PAUSE_MAX`` (a silent controller must not keep
#: its loop busy with stops for the whole read-back).
RETRY_PAUSE = 0.2
RETRY_PAUSE_MAX = 2.0


@dataclass(frozen=True)
class Occasion:
    """Why a hold-to-run motion has nobody holding it, as its stop and its verdict say it."""

    event: str  # the audit entry's ``event``
    left: str  # the log's words for how it was left running
    kind: str  # the ``OperationError.kind`` of the verdict
    title: str  # the verdict's title when the stop took effect
    while_: str  # "<what happened> while the <kind> ..." in the verdict's detail

    def context(self, op: Operation) -> str:
        """How the motion came to be unheld, for the verdict's detail."""
        return self.while_.format(
            kind=op.kind, state=op.state.value, loop=op.axis.loop, controller=op.axis.controller_id
        )


#: A jog in flight when the gateway process died.
AT_RESTART = Occasion(
    "restart_stop", "was left running by the last process", "restart", "Stopped at restart",
    "the gateway restarted while the {kind} was {state}",
)  # fmt: skip
#: A jog whose loop went down while it ran, stopped once the loop is up again.
AT_LINK_UP = Occasion(
    "linkup_stop", "ran while its loop was down", "loop_down",
    "Stopped when the loop came back", "loop {loop} went down while the {kind} ran",
)  # fmt: skip
#: A jog whose controller alone stopped answering while it ran (its own wiring on the current
#: loop, a failing receiver), stopped once it answers again.
AT_ANSWER = Occasion(
    "answer_stop", "ran while its controller was silent", "offline",
    "Stopped when the controller answered again",
    "controller {controller} stopped answering while the {kind} ran",
)  # fmt: skip


@dataclass
class RestartStop:
    """What the stop of ``operation``, sent at restart, did."""

    operation: Operation
    command: str
    outcome: Outcome = Outcome.NOT_DONE
    frames: list[str] = field(default_factory=list)
    error: str | None = None
    time: float = field(default_factory=time.time)
    occasion: Occasion = AT_RESTART

    @property
    def sent(self) -> bool:
        """True when the controller took the stop ('>')."""
        return self.outcome is Outcome.DONE

    def audit_entry(self, prefix: str) -> dict[str, Any]:
        """The audit entry of the stop: no request made it, the gateway did on its own."""
        op = self.operation
        stamp = datetime.fromtimestamp(self.time, UTC).isoformat(timespec="milliseconds")
        return {
            "time": stamp.replace("+00:00", "Z"),
            "token": op.holder,
            "method": "STOP",
            "path": f"{prefix}/controllers/{op.axis.controller_id}/stop",
            "event": self.occasion.event,
            "bytes_sent": list(self.frames),
            "result": self.outcome.value,
            "error": self.error,
            "operation": op.id,
        }


async def stop_left_running(
    runtime: Runtime, op: Operation, give_up: float, occasion: Occasion = AT_RESTART
) -> RestartStop:
    """Send ``SS`` to the controller of ``op`` as soon as its loop is up, trying again until
    the loop time ``give_up``; what was sent and how it went."""
    command = cmd.slow_stop()
    stop = RestartStop(op, command.wire(), occasion=occasion)
    scheduler = runtime.scheduler(op.axis.loop)
    loop = asyncio.get_running_loop()
    pause = RETRY_PAUSE
    while True:
        if scheduler.state is not LinkState.UP:
            await link_up(runtime, op.axis.loop, give_up - loop.time())
        try:
            result = await scheduler.stop(op.axis.body, command)
        except LoopDown as exc:
            stop.outcome = Outcome.UNKNOWN if exc.in_flight else Outcome.NOT_DONE
            stop.error = str(exc)
        except Exception as exc:  # expired, refused before the line: nothing was sent
            stop.outcome, stop.error = Outcome.NOT_DONE, str(exc) or type(exc).__name__
        else:
            stop.outcome = result.outcome
            stop.frames = result.frames
            stop.error = None if result.outcome is Outcome.DONE else _why(result.outcome)
        stop.time = time.time()
        # A refusal ('>@') is the controller's answer: sending it again would change nothing.
        refused = stop.frames and stop.outcome is Outcome.NOT_DONE
        if stop.sent or refused or loop.time() >= give_up:
            break
        await asyncio.sleep(pause)  # a back-off between attempts, not a synchronisation
        pause = min(pause * 2, RETRY_PAUSE_MAX)
    _log(stop)
    return stop


async def link_up(runtime: Runtime, name: str, timeout: float | None) -> None:
    """Until loop ``name`` is up (woken by its ``LinkUp``), at most ``timeout`` seconds
    (None: however long it takes)."""
    scheduler = runtime.scheduler(name)
    up = asyncio.Event()

    def seen(event: object) -> None:
        if isinstance(event, LinkUp):
            up.set()

    unsubscribe = scheduler.events.subscribe(seen)
    try:
        if scheduler.state is not LinkState.UP:
            await asyncio.wait_for(up.wait(), None if timeout is None else max(timeout, 0.0))
    except TimeoutError:
        pass  # the attempt after this fails with the loop's own reason
    finally:
        unsubscribe()


def _why(outcome: Outcome) -> str:
    if outcome is Outcome.NOT_DONE:
        return "the controller refused the stop"
    return "the reply to the stop was lost"


def _log(stop: RestartStop) -> None:
    op = stop.operation
    if stop.sent:
        log.warning(
            "operation %s: the %s on axis %s %s; stopped it: %s",
            op.id, op.kind, op.axis.id, stop.occasion.left, " ".join(stop.frames),
        )  # fmt: skip
    else:
        log.error(
            "operation %s: the %s on axis %s %s and could not be stopped (%s): %s",
            op.id, op.kind, op.axis.id, stop.occasion.left, stop.outcome.value, stop.error,
        )  # fmt: skip


def tell(listeners: list[Callable[[RestartStop], object]], stop: RestartStop) -> None:
    """Give ``stop`` to each of ``listeners`` (the audit): one failing spoils no other."""
    for callback in list(listeners):
        try:
            callback(stop)
        except Exception:  # one bad listener must not stop the others
            log.exception("operation %s: stop listener failed", stop.operation.id)
