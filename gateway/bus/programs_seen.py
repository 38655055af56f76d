"""Which controllers of a loop may have a user program printing on the line.

A running program's ``/CO`` output is ``>text`` CR (§12 /CO): it names no controller, and with
EL0 its '>' looks like the '>' of a reply (§9-2). Two things depend on knowing that a program
may be printing:

* the reply parser waits for the byte after a general command's '>' only then (text after it
  is a ``/CO`` line, not the reply; otherwise the '>' is the reply at once, which keeps the
  line fast: ``ReplyParser.configure(printing=...)``);
* output that names no controller is attributed to the one controller whose program may run,
  when there is exactly one (with more, it stays unattributed: the gateway cannot know).

What is sent and seen on the bus decides it: ``G``/``G{lb}``/``GC`` sent (a program starts or
goes on), ``GSS`` read '1' or 'P' (running, paused); a ``GSS`` of '0' or 'E', or ``GE``/``GES``
accepted, end it. A program started at power-on (GA, §11-3 4.) is seen at the poller's next
``GSS`` read. Program output is not taken as a sign: on a noisy line a damaged reply can look
like it, and a wrong "printing" would slow every reply of the loop.
"""

from __future__ import annotations

from gateway.bus.events import BusEvent, ReplyObserved
from gateway.protocol.commands import PROGRAM_ENDS, PROGRAM_STARTS
from gateway.protocol.models import Command
from gateway.protocol.reply_values import ProgramState

__all__ = ["ProgramsSeen"]


class ProgramsSeen:
    """The controllers of one loop whose user program may be running (see the module)."""

    def __init__(self) -> None:
        self._bodies: set[str] = set()

    @property
    def printing(self) -> bool:
        """Whether any program of the loop may be running (and printing)."""
        return bool(self._bodies)

    def may_run(self, body: str) -> bool:
        """Whether ``body``'s program may be running: it may select a motor at any time."""
        return body in self._bodies

    def sole(self) -> str | None:
        """The body number of the one controller whose program may run; None otherwise."""
        return next(iter(self._bodies)) if len(self._bodies) == 1 else None

    def sending(self, body: str, command: Command) -> None:
        """``command`` goes to ``body`` now. A program started by ``G``/``GC`` prints from
        2 ms after the frame (docs/manual-notes.md "Statement time"), right behind the '>'
        of G and before the scheduler has seen that '>': count it as running from the send
        (a ``G`` the device refuses is corrected by the ``GSS`` that follows it)."""
        if command.form in PROGRAM_STARTS:
            self._bodies.add(body)

    def handle(self, event: BusEvent) -> None:
        """Follow the loop's bus events (subscribe this to the scheduler's ``events``)."""
        if isinstance(event, ReplyObserved) and not event.rejected:
            form, value = event.command.form, event.value
            if form in PROGRAM_STARTS and value is None:
                self._bodies.add(event.body)
            elif form in PROGRAM_ENDS and value is None:
                self._bodies.discard(event.body)
            elif isinstance(value, ProgramState):
                if value in (ProgramState.RUNNING, ProgramState.PAUSED):
                    self._bodies.add(event.body)
                else:
                    self._bodies.discard(event.body)
