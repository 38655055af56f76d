"""The scheduler of one serial loop: the only writer to its port (DESIGN invariant 1).

``LoopScheduler.submit`` queues a transaction (commands to one controller that no other request
interleaves) and returns its ``TransactionResult``; ``stop`` sends a stop at stop priority;
``upload_program`` uploads a user program as one transaction. What happens on the line is
published on ``events``; ``counters`` and ``trace`` describe the loop. How the queue is served,
and how the loop goes down and comes back, is ``lifecycle``.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Sequence

from gateway.bus.lifecycle import LinkState, LoopLifecycle
from gateway.bus.requests import Priority, TransactionError, TransactionResult
from gateway.bus.trace import FrameDirection
from gateway.protocol import commands as cmd
from gateway.protocol.command_text import REGISTRY
from gateway.protocol.framing import BODY_NUMBERS, Framing
from gateway.protocol.models import Command
from gateway.protocol.program import Program

__all__ = ["LinkState", "LoopScheduler"]

#: The stops' texts, for the errors that refuse something else at stop priority.
_STOPS = ", ".join(sorted(entry.key for entry in REGISTRY.entries if entry.form.is_stop))


class LoopScheduler(LoopLifecycle):
    """Queue, priorities, transactions and link health of one loop.

    ``LoopScheduler(transport, LoopConfig(...))``; ``await start()`` opens the port (one
    attempt; reconnecting goes on in the background); ``await close()`` ends it.
    """

    # ------------------------------------------------------------------ public

    async def start(self) -> None:
        """Open the port (one attempt) and start serving; reconnects in the background."""
        if self._task is None:
            self._task = asyncio.get_running_loop().create_task(self._run(), name=self.name)
        await self._first_attempt.wait()

    async def close(self, *, drain: float = 0.0) -> None:
        """Stop: queued and later requests fail with ``LoopDown``; the port is closed.

        ``drain``: real seconds to let the transaction in flight finish first (graceful
        shutdown: a move half-sent is worse than one refused).
        """
        self.state = LinkState.CLOSED
        self.cause = "the scheduler was closed"
        self._fail_queued()
        if drain > 0:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._idle.wait(), drain)
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
            self._task = None
        await self._link.stop()
        with contextlib.suppress(Exception):
            await self.transport.close()

    async def submit(
        self,
        body: str,
        commands: Command | Sequence[Command],
        *,
        priority: Priority = Priority.OPERATOR,
        motor: int | None = None,
        deadline: float | None = None,
    ) -> TransactionResult:
        """Run ``commands`` on controller ``body`` as one transaction; its result.

        ``motor``: the motor the per-motor commands without a suffix are for (the scheduler
        sends ``F{motor}`` first when needed); None: whatever is selected. ``deadline``: host
        seconds the request may wait to start (default per priority, ``LoopConfig``).
        Raises ``LoopDown``, ``DeadlineExpired``, ``TransactionError``.
        """
        cmds = (commands,) if isinstance(commands, Command) else tuple(commands)
        return await self._submit(body, cmds, priority, motor, deadline, None)

    async def stop(self, body: str, command: Command | None = None) -> TransactionResult:
        """Send a stop (``S`` by default, ``SS`` or ``GES``) at stop priority."""
        command = cmd.stop() if command is None else command
        if not command.form.is_stop:
            raise TransactionError(f"{command.wire()!r} is not a stop: one of {_STOPS}")
        return await self.submit(body, command, priority=Priority.STOP)

    async def upload_program(
        self,
        body: str,
        program: Program,
        *,
        priority: Priority = Priority.OPERATOR,
        deadline: float | None = None,
    ) -> TransactionResult:
        """Upload a user program: ``I``, then its text ended by CR, as one transaction."""
        return await self._submit(body, (cmd.upload_program(),), priority, None, deadline, program)

    def forget(self, body: str | None = None) -> None:
        """Drop what the scheduler knows of a controller's selection and framing (power cycle)."""
        if body is None:
            self._forget_all()
        else:
            self._core.set_selection(body, None)
        self._core.framing.forget(body)
        if body is None:
            self._core.detect_failed.clear()
        else:
            self._core.detect_failed.discard(body)

    def selected_motor(self, body: str) -> int | None:
        """The motor the scheduler believes selected on ``body`` (None: not known)."""
        return self._core.selected(body)

    def program_may_run(self, body: str) -> bool:
        """Whether ``body``'s user program may be running (``ProgramsSeen``)."""
        return self._programs.may_run(body)

    def resync_figures(self) -> tuple[int, float]:
        """Resyncs of the line so far (after time-outs included) and the host seconds they
        held it (``Link.resync``)."""
        return self._link.resyncs, self._link.resync_time

    def framing(self, body: str) -> Framing:
        """The framing the scheduler uses for ``body``."""
        return self._core.framing.get(body)

    @property
    def queue_depth(self) -> int:
        """Requests waiting to start."""
        return len(self._queue)

    # ------------------------------------------------------------------ submitting

    async def _submit(
        self,
        body: str,
        commands: tuple[Command, ...],
        priority: Priority,
        motor: int | None,
        deadline: float | None,
        program: Program | None,
    ) -> TransactionResult:
        if len(body) != 1 or body not in BODY_NUMBERS:
            raise TransactionError(f"body number {body!r} is not one of 0-E (§9-1)")
        if not commands or not all(isinstance(c, Command) for c in commands):
            raise TransactionError("a transaction is one or more command models (never text)")
        if motor not in (None, 1, 2):
            raise TransactionError(f"motor must be 1 or 2, not {motor!r}")
        if self.state in (LinkState.DOWN, LinkState.CLOSED):
            raise self._down_error()
        if all(c.form.is_stop for c in commands):
            priority = Priority.STOP  # a stop outranks everything queued (DESIGN invariant 8)
        elif priority is Priority.STOP:
            # Stop priority jumps the queue, never expires and survives its caller: it is
            # for stops only, or any caller could starve the line with it.
            raise TransactionError(
                f"priority STOP is for stops only ({_STOPS}); "
                f"this transaction has {', '.join(c.wire() for c in commands)}"
            )
        if deadline is None:
            deadline = self.config.deadline_for(priority)
        if priority is Priority.STOP:  # when it was asked for, beside when it went out
            self.trace.add(self.clock(), FrameDirection.NOTE, body, b"", "stop queued")
        waiter = self._queue.put(
            body, commands, priority=priority, motor=motor, program=program, deadline=deadline
        )
        try:
            return await waiter.future
        except asyncio.CancelledError:
            self._queue.discard(waiter)
            raise
